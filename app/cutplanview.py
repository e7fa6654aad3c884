"""The Cut plan panel (issue 43): the document's solved pieces nested on the roll, a marker per
material (:func:`flatweave.document.cutplan.project_items`, grouped by
:func:`flatweave.document.cutplan.by_material`, each group placed by
:func:`flatweave.studies.nesting.nest`), drawn by :class:`MarkerView`: the roll along x, each
placed copy's cut outline filled in its item's colour and named when the name fits inside it, a
legend of the items, the marker's end and a scale along the roll. Beside it the chosen
material's numbers: length (m), utilisation (%), waste (m^2), copies placed and the time.

Its controls: the material shown (a marker each), that material's roll width (mm; the
materials table's ``roll_width_mm`` until typed, else :data:`DEFAULT_ROLL_MM`), and for every
material the gap, the time limit (per material), the seam allowance and the splice overlap; the pieces
cut in mirror pairs (a checkable list: a left and a right panel, half a piece's copies its mirror image);
Nest and Stop. These settings are the project's cut plan
(:class:`flatweave.document.cutsettings.CutPlanSettings`, saved with it): the widgets show
``project.cut_plan`` after every change of the document (an undo, another document), and an edit of one
of them is asked for by ``plan_edited(plan, label)`` (the window makes it one undoable edit of the
document, which comes back through :meth:`CutPlanPanel.set_project`). Nest
runs in a ``threading.Thread`` of its own (the window stays live): each better marker the
engine finds is handed to this thread by a signal and drawn at once (``progress(material,
marker)``); Stop ends it at once, the best marker so far staying shown ("stopped: the best so
far"), and the materials not reached yet are not nested. Every Nest ends with exactly one of
``finished(summary)`` and ``failed(message)`` (one line: a piece wider than the roll, no piece
solved; a material that failed has no marker, the others keep theirs). Pieces not solved (or
solved before their last change) are said as left out.

The panel never changes the document: a marker is a view of the pieces it was nested from, and
once those change (a piece solved again, edited, added, deleted, a seam's allowance, the units)
it says so ("pieces changed since: Nest again") and draws the marker faded; another document
drops it.

Splices (a piece wider than the roll, :func:`flatweave.document.cutplan.splice_items`): the shown material's
spliced pieces are listed in a small table (piece, width across, the splices' positions in mm from the piece's
edge, chosen or placed by hand); a position typed there ("700", or "700, 1400") is checked against that piece
at once (a refused one is ``input_error(message)``, one line, and nothing else changes), kept in the project's
cut plan and re-nests with it; a cleared cell or Reset goes back to the chosen splices. Beside the table,
:class:`SpliceView` draws the selected row's piece flat, turned so the splices run along the roll, with the
roll's usable width: a splice line dragged up or down there is placed as typed. :meth:`CutPlanPanel.piece_splices`
gives the document's active piece's splices in the markers shown (none when stale), which the window draws on
the surface; ``splices_changed`` says when they may have changed. :meth:`CutPlanPanel.shutdown` (the window's
close) stops a nest and waits for its thread. No VTK here."""

from __future__ import annotations

import math
import re
import sys
import threading
import traceback
from dataclasses import replace

import numpy as np
from PySide6.QtCore import QPointF, QRectF, QSignalBlocker, QSize, Qt, Signal
from PySide6.QtGui import QBrush, QColor, QFont, QFontMetricsF, QPainter, QPen, QPolygonF
from PySide6.QtWidgets import (QAbstractItemView, QComboBox, QDoubleSpinBox, QFormLayout, QHBoxLayout, QHeaderView,
                               QLabel, QListWidget, QListWidgetItem, QPushButton, QSizePolicy, QSpinBox, QTableWidget,
                               QTableWidgetItem, QVBoxLayout, QWidget)
from shapely.geometry import Polygon
from shapely.ops import polylabel

from flatweave.app.worker import one_line
from flatweave.document.cutplan import PlanItem, SpliceReport, by_material, project_items, splice_items
from flatweave.document.cutsettings import CutPlanSettings
from flatweave.document.project import Project
from flatweave.document.sewing import MAX_ALLOWANCE_MM
from flatweave.errors import FlatweaveError, SettingsError
from flatweave.geometry.numerics import rotate
from flatweave.studies.nesting import DEFAULT_SECONDS, Marker, nest, usable_width

__all__ = ["CutPlanPanel", "MarkerView", "SpliceView", "piece_colour", "same_pieces", "read_splices",
           "DEFAULT_ROLL_MM", "STOPPED", "STALE", "NUMBERS", "SPLICE_COLUMNS", "MIRROR_TIP"]

DEFAULT_ROLL_MM = 1500.0  # a material the table gives no roll width
STOPPED = "stopped: the best so far"
STALE = "pieces or cut plan changed since: Nest again"
NUMBERS = (("length", "Length"), ("utilisation", "Utilisation"), ("waste", "Waste"), ("placed", "Placed"),
           ("time", "Time"))
# Tableau's ten: told apart on screen and in grey print; more items than these get hues a golden angle apart
PALETTE = ("#4e79a7", "#f28e2b", "#e15759", "#76b7b2", "#59a14f", "#edc948", "#b07aa1", "#ff9da7", "#9c755f",
           "#bab0ac")
ROLL_FILL, ROLL_EDGE, END_COLOUR, STALE_COLOUR = "#fbfaf5", "#505050", "#b00020", "#b86e00"
SPLICE_COLUMNS = (("Piece", "The piece spliced (its pattern's piece number when it has several)"),
                  ("Across", "The piece's width across the roll"),
                  ("Splices", "The splices' positions across the piece, mm from its edge: double-click to type "
                              "them (700, or 700, 1400), cleared to go back to the ones chosen"),
                  ("By", "chosen (through the least shear) or placed by hand"))
SPLICES = 2  # the editable column
MIRROR_TIP = ("A left and a right panel: half its copies cut as the mirror image (an odd number has one more as "
              "drawn). Checked pieces are nested so at the next Nest")
SPLICE_LINE, SPLICE_DRAGGED, PART_FITS, PART_TOO_WIDE = "#1f5fbf", "#e07000", "#2e7d32", END_COLOUR


def piece_colour(k: int) -> QColor:
    """Item ``k``'s colour (its copies are filled with it)."""
    if k < len(PALETTE):
        return QColor(PALETTE[k])
    return QColor.fromHsvF((k * 0.618034) % 1.0, 0.55, 0.85)


def _inputs(project: Project) -> tuple:
    """What a cut plan is made of (the pieces' names, quantities, laying order, settings and results, the
    seams (their allowances), the units): objects compared by identity, the project being immutable."""
    return (project.units, project.sewings,
            tuple((p.name, p.quantity, p.sequence, p.settings, p.result) for p in project.pieces))


def same_pieces(a: Project, b: Project) -> bool:
    """Whether ``a`` and ``b`` make the same cut plan: the same pieces (names, quantities, laying order)
    with the same settings and results, the same seams and units. An edit that makes a new settings or
    result object counts as a change even when it comes back to equal values (a marker is then said stale
    where it was not: never the other way)."""
    ua, sa, pa = _inputs(a)
    ub, sb, pb = _inputs(b)
    return ua == ub and sa is sb and len(pa) == len(pb) and all(
        x[:3] == y[:3] and x[3] is y[3] and x[4] is y[4] for x, y in zip(pa, pb))


def _step_above(mm: float) -> float:
    """The smallest 1, 2 or 5 times a power of ten not below ``mm`` (> 0): a scale's step."""
    p = 10.0 ** math.floor(math.log10(mm)) if mm > 0 and math.isfinite(mm) else 1.0
    return min(f * p for f in (1.0, 2.0, 5.0, 10.0) if f * p >= mm * (1 - 1e-12))


def _length_m(mm: float) -> str:
    return f"{mm / 1000.0:.3f} m"


def _mm(value: float) -> str:
    return f"{round(float(value), 1):g}"


def read_splices(text: str) -> list[float]:
    """Splice positions typed in the table ("700", "700, 1400"; commas, semicolons or spaces apart), mm;
    [] for an empty text (the chosen splices). ValueError (one line) for anything else."""
    words = text.replace(",", " ").replace(";", " ").split()
    try:
        out = [float(w.removesuffix("mm")) for w in words]
    except ValueError:
        raise ValueError(f"{text.strip()!r} is not a list of positions in mm (as 700, or 700, 1400)") from None
    if not all(math.isfinite(v) for v in out):
        raise ValueError(f"{text.strip()!r}: a position must be a finite number of mm")
    return out


class MarkerView(QWidget):
    """A marker drawn with QPainter: the roll (x along it, left to right; y across it, 0 at the
    bottom, so a piece reads face up as in the marker's files) scaled to fit the widget with its
    aspect ratio kept (a long roll shrinks), the placed copies' cut outlines filled, one colour per
    item, named when the name fits (a mirror pair's mirrored copy edged dashed, "NAME (mirrored)" when
    that fits), a legend above, the marker's end (a red line and its length) and a scale along the roll
    below. ``message`` is drawn when there is no marker; a ``stale`` marker is
    faded and says so."""

    MARGIN = 12.0
    SCALE_BAND = 26.0  # under the roll: the ticks and their lengths
    END_ROOM = 64.0  # right of the roll: the end's length label

    def __init__(self, parent=None):
        super().__init__(parent)
        self.marker: Marker | None = None
        self.message = ""
        self.stale = False
        self._outlines: list[np.ndarray] = []  # mm, on the roll, each placement's
        self._labels: list[tuple[float, float, float]] | None = None  # each one's label point and room (mm)
        self.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Expanding)
        self.setMinimumSize(240, 160)

    def sizeHint(self) -> QSize:
        return QSize(720, 300)

    def set_marker(self, marker: Marker | None, message: str = "") -> None:
        """Draw ``marker`` (None: ``message`` instead)."""
        if marker is not self.marker:
            self._outlines = [] if marker is None else marker.outlines()
            self._labels = None  # found when first painted: a live nest hands over markers faster than paints
        self.marker, self.message = marker, message
        self.update()

    def _label_points(self) -> list[tuple[float, float, float]]:
        """Each placed copy's label point and how far inside its outline that point is (mm)."""
        if self._labels is None:
            self._labels = []
            for outline in self._outlines:
                poly = Polygon(outline)
                if not poly.is_valid:
                    poly = poly.buffer(0)
                if poly.geom_type != "Polygon" or poly.is_empty:
                    self._labels.append((float(outline[:, 0].mean()), float(outline[:, 1].mean()), 0.0))
                    continue
                # the point farthest inside (a concave piece's centroid may lie outside it), and how far in it is
                centre = polylabel(poly, max(1e-3 * math.sqrt(poly.area), 1e-6))
                self._labels.append((centre.x, centre.y, float(poly.exterior.distance(centre))))
        return self._labels

    def set_stale(self, stale: bool) -> None:
        if bool(stale) != self.stale:
            self.stale = bool(stale)
            self.update()

    # ------------------------------------------------------------------ geometry (what paint draws)
    def _legend(self, width: float) -> list[tuple[int, QRectF]]:
        """Each item's legend entry (item index, its rectangle: a swatch then the name), wrapped to ``width``."""
        if self.marker is None:
            return []
        fm = QFontMetricsF(self.font())
        h, x, y, out = fm.height(), self.MARGIN, self.MARGIN, []
        for k, item in enumerate(self.marker.items):
            w = h + 4.0 + fm.horizontalAdvance(item.name)
            if x > self.MARGIN and x + w > width - self.MARGIN:
                x, y = self.MARGIN, y + h + 4.0
            out.append((k, QRectF(x, y, w, h)))
            x += w + 14.0
        return out

    def _frame(self) -> tuple[float, float, float, float] | None:
        """(scale px/mm, left, bottom, top) of the roll in the widget (None: nothing to draw): the
        used roll's length and its width fit what the legend and the scale leave, the aspect kept."""
        m = self.marker
        if m is None or m.length <= 0 or m.roll_width <= 0:
            return None
        legend = self._legend(self.width())
        top = (legend[-1][1].bottom() if legend else self.MARGIN) + 8.0
        room_w = self.width() - 2 * self.MARGIN - self.END_ROOM
        room_h = self.height() - top - self.SCALE_BAND - self.MARGIN
        if room_w <= 4 or room_h <= 4:
            return None
        s = min(room_w / m.length, room_h / m.roll_width)
        return s, self.MARGIN, top + m.roll_width * s, top

    def to_pixels(self, points) -> np.ndarray:
        """(k, 2) roll points (mm) in widget pixels as drawn now (empty when nothing is drawn)."""
        frame = self._frame()
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        if frame is None:
            return np.zeros((0, 2))
        s, left, bottom, _ = frame
        return np.column_stack([left + p[:, 0] * s, bottom - p[:, 1] * s])

    def roll_rect(self) -> QRectF | None:
        """The used roll (0 to the marker's length, 0 to its width) in widget pixels, or None."""
        frame = self._frame()
        if frame is None:
            return None
        s, left, bottom, top = frame
        return QRectF(left, top, self.marker.length * s, bottom - top)

    def painted(self) -> list[tuple[str, np.ndarray]]:
        """Each placed copy as painted: its item's name and its cut outline in widget pixels, in the
        marker's placements' order (empty when no marker is drawn)."""
        if self._frame() is None:
            return []
        return [(self.marker.items[p.item].name, self.to_pixels(o))
                for p, o in zip(self.marker.placements, self._outlines)]

    # ------------------------------------------------------------------ paint
    def paintEvent(self, _event) -> None:
        p = QPainter(self)
        try:
            p.setRenderHint(QPainter.RenderHint.Antialiasing)
            p.fillRect(self.rect(), self.palette().window())
            frame = self._frame()
            if frame is None:
                p.setPen(self.palette().color(self.foregroundRole()))
                p.drawText(self.rect().adjusted(12, 12, -12, -12),
                           Qt.AlignmentFlag.AlignCenter | Qt.TextFlag.TextWordWrap, self.message)
                return
            self._paint_marker(p, frame)
        finally:
            p.end()

    def _paint_marker(self, p: QPainter, frame) -> None:
        m = self.marker
        s, left, bottom, top = frame
        fm = QFontMetricsF(self.font())
        roll = self.roll_rect()
        # the roll goes on past the marker: drawn faint to the widget's edge
        on = QRectF(roll.right(), top, max(self.width() - self.MARGIN - roll.right(), 0.0), roll.height())
        p.fillRect(on, QColor("#eeeeea"))
        p.fillRect(roll, QColor(ROLL_FILL))
        p.setPen(QPen(QColor(ROLL_EDGE), 1.0))
        p.drawLine(QPointF(left, top), QPointF(self.width() - self.MARGIN, top))
        p.drawLine(QPointF(left, bottom), QPointF(self.width() - self.MARGIN, bottom))
        p.drawLine(QPointF(left, top), QPointF(left, bottom))

        p.setOpacity(0.35 if self.stale else 1.0)
        for (name, pixels), placement, (lx, ly, room) in zip(self.painted(), m.placements, self._label_points()):
            colour = piece_colour(placement.item)
            p.setBrush(QBrush(colour.lighter(125)))
            # a mirror pair's mirrored copy: its edge dashed, and said when there is room
            edge = Qt.PenStyle.DashLine if placement.mirrored else Qt.PenStyle.SolidLine
            p.setPen(QPen(colour.darker(160), 1.0, edge))
            p.drawPolygon(QPolygonF([QPointF(x, y) for x, y in pixels]))
            h = fm.height()
            texts = [f"{name} (mirrored)", name] if placement.mirrored else [name]
            for text in texts:
                w = fm.horizontalAdvance(text)
                if w <= 2.0 * room * s and h <= room * s:  # the name fits inside the piece
                    at = self.to_pixels([(lx, ly)])[0]
                    p.setPen(QColor("#111111"))
                    p.drawText(QRectF(at[0] - w / 2 - 2, at[1] - h / 2, w + 4, h), Qt.AlignmentFlag.AlignCenter, text)
                    break
        p.setOpacity(1.0)

        # the marker's end: where the cutter stops
        end = left + m.length * s
        p.setPen(QPen(QColor(END_COLOUR), 1.5, Qt.PenStyle.DashLine))
        p.drawLine(QPointF(end, top - 4.0), QPointF(end, bottom + 4.0))
        p.drawText(QPointF(end + 4.0, top + fm.ascent()), _length_m(m.length))

        # a scale along the roll, in metres
        # at most five steps, and labels apart on screen by their width and a gap
        step = _step_above(max(m.length / 5.0, (fm.horizontalAdvance(f"{m.length / 1000.0:.1f}") + 16.0) / s))
        p.setPen(QPen(QColor(ROLL_EDGE), 1.0))
        ticks = np.arange(0.0, m.length + 1e-9, step)
        for k, x in enumerate(ticks):
            px = left + x * s
            p.drawLine(QPointF(px, bottom), QPointF(px, bottom + 5.0))
            text = f"{x / 1000.0:g}" + (" m" if k == len(ticks) - 1 else "")  # the unit once, after the last
            number = fm.horizontalAdvance(f"{x / 1000.0:g}")
            p.drawText(QPointF(px - number / 2, bottom + 6.0 + fm.ascent()), text)
        p.drawText(QPointF(end + 4.0, bottom - 4.0), f"{m.roll_width:g} mm roll")

        for k, rect in self._legend(self.width()):
            colour = piece_colour(k)
            swatch = QRectF(rect.left(), rect.top() + 2.0, rect.height() - 4.0, rect.height() - 4.0)
            p.setBrush(QBrush(colour.lighter(125)))
            p.setPen(QPen(colour.darker(160), 1.0))
            p.drawRect(swatch)
            p.setPen(self.palette().color(self.foregroundRole()))
            p.drawText(QPointF(rect.left() + rect.height(), rect.top() + fm.ascent()), m.items[k].name)
        if self.stale:
            font = QFont(self.font())
            font.setBold(True)
            p.setFont(font)
            p.setPen(QColor(STALE_COLOUR))
            p.drawText(QRectF(left, top, roll.width() + on.width(), roll.height()), Qt.AlignmentFlag.AlignCenter,
                       STALE[0].upper() + STALE[1:])


class SpliceView(QWidget):
    """A spliced piece drawn flat, turned so its splices run along the roll (x along it, y across it, up the
    screen as the marker has it): its outline before splicing, the roll's usable width as a band from the
    edge of the part below the splice dragged (the piece's edge when none is), each splice a line across it
    with its overlap shaded and its position (mm from the piece's edge, as the table says), and beside the
    piece each part's width across, green when it fits the roll, red when not. A splice line dragged up or
    down with the mouse (or :meth:`drag_splice`) asks for the splices there: ``moved(name, positions)``
    (mm from the edge, 0.1 mm, in order) on release; the lines are drawn where the report has them again at
    once (a refused drag snaps back; a taken one is drawn where it went once the piece is nested again)."""

    moved = Signal(str, object)  # the item's name, its splices' positions asked (mm from its edge)

    MARGIN = 8.0
    RIGHT = 84.0  # right of the piece: the parts' brackets and the splices' positions
    GRAB_PX = 6.0  # a press this near a splice line takes it

    def __init__(self, parent=None):
        super().__init__(parent)
        self.report: SpliceReport | None = None
        self.outline = np.zeros((0, 2))  # the piece's outline in the turned frame (mm)
        self.usable = 0.0  # the roll's usable width (mm)
        self.overlap = 0.0
        self._source = None  # the outline as given (its item's frame)
        self._at: list[float] = []  # the splices' y in the turned frame as drawn (a drag moves one)
        self._drag: int | None = None  # the splice being dragged (its index in the report's positions)
        self.setMouseTracking(True)
        self.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Expanding)
        self.setMinimumSize(220, 120)
        self.setToolTip("The selected piece flat, turned so its splices run along the roll: drag a splice line "
                        "up or down to place it there (the parts must each fit the roll's usable width, the "
                        "shaded band); the pieces are nested again")

    def sizeHint(self) -> QSize:
        return QSize(340, 150)

    def set_piece(self, report: SpliceReport | None, outline=None, usable: float = 0.0,
                  overlap: float = 0.0) -> None:
        """Show ``report``'s piece (None: nothing): ``outline`` its cut outline before splicing, mm in its
        item's own frame; ``usable`` the roll's usable width and ``overlap`` the splices' (mm). The same
        piece again leaves a drag under way alone."""
        if report is self.report and outline is self._source and (usable, overlap) == (self.usable, self.overlap):
            return
        self.report, self._source, self.usable, self.overlap = report, outline, float(usable), float(overlap)
        self.outline = (np.zeros((0, 2)) if report is None or outline is None
                        else rotate(outline, -report.frame_deg))
        self._at = [] if report is None else [float(y) for y in report.positions]
        self._drag = None
        self.update()

    def positions(self) -> list[float]:
        """The splices as drawn, mm from the piece's edge (what the table says, or where a drag has one)."""
        return [] if self.report is None else [y - self.report.start for y in self._at]

    def parts(self) -> list[tuple[float, float]]:
        """Each part's extent across the roll in the turned frame (its lowest and highest y, mm, the overlap
        taken at each splice), as the splices drawn make them, bottom to top."""
        if self.report is None:
            return []
        edges = [self.report.start] + sorted(self._at) + [self.report.start + self.report.width]
        half, last = 0.5 * self.overlap, len(edges) - 2
        return [(edges[k] - (half if k > 0 else 0.0), edges[k + 1] + (half if k < last else 0.0))
                for k in range(len(edges) - 1)]

    # ------------------------------------------------------------------ geometry
    def _frame(self) -> tuple[float, float, float, float, float] | None:
        """(scale px/mm, the piece's least x and y (mm), its left and bottom in pixels), or None."""
        r = self.report
        if r is None or len(self.outline) < 3 or r.width <= 0:
            return None
        x0, x1 = float(self.outline[:, 0].min()), float(self.outline[:, 0].max())
        top = self.MARGIN + QFontMetricsF(self.font()).height() + 6.0
        room_w = self.width() - 2 * self.MARGIN - self.RIGHT
        room_h = self.height() - top - self.MARGIN
        if room_w <= 4 or room_h <= 4 or x1 <= x0:
            return None
        s = min(room_w / (x1 - x0), room_h / r.width)
        left = self.MARGIN + 0.5 * (room_w - (x1 - x0) * s)
        return s, x0, r.start, left, top + 0.5 * (room_h + r.width * s)

    def to_pixels(self, points) -> np.ndarray:
        """(k, 2) points of the turned frame (mm; y as the report's positions) in widget pixels as drawn now
        (empty when nothing is drawn)."""
        frame = self._frame()
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        if frame is None:
            return np.zeros((0, 2))
        s, x0, y0, left, bottom = frame
        return np.column_stack([left + (p[:, 0] - x0) * s, bottom - (p[:, 1] - y0) * s])

    def line_pixels(self, k: int) -> QPointF:
        """The middle of splice ``k``'s line in widget pixels (where a press takes it)."""
        x = 0.5 * (self.outline[:, 0].min() + self.outline[:, 0].max())
        px, py = self.to_pixels([(x, self._at[k])])[0]
        return QPointF(px, py)

    def _y_at(self, py: float) -> float | None:
        """The turned frame's y (mm) at pixel row ``py``, within the piece."""
        frame = self._frame()
        if frame is None:
            return None
        s, _, y0, _, bottom = frame
        return min(max(y0 + (bottom - py) / s, y0), y0 + self.report.width)

    def _line_near(self, pos: QPointF) -> int | None:
        """The splice whose line is nearest ``pos`` within GRAB_PX (None: none)."""
        if self._frame() is None or not self._at:
            return None
        xs = self.to_pixels([(self.outline[:, 0].min(), 0.0), (self.outline[:, 0].max(), 0.0)])[:, 0]
        if not xs[0] - self.GRAB_PX <= pos.x() <= xs[1] + self.GRAB_PX:
            return None
        ys = self.to_pixels([(0.0, y) for y in self._at])[:, 1]
        k = int(np.argmin(np.abs(ys - pos.y())))
        return k if abs(ys[k] - pos.y()) <= self.GRAB_PX else None

    # ------------------------------------------------------------------ dragging
    def drag_splice(self, k: int, to_mm: float) -> list[float]:
        """Splice ``k`` moved to ``to_mm`` mm from the piece's edge, as a drag released there does: the
        positions asked (``moved`` emitted when they differ from the report's)."""
        if self.report is None or not 0 <= k < len(self._at):
            return []
        self._at[k] = self.report.start + float(to_mm)
        self._drag = k
        return self._release()

    def _release(self) -> list[float]:
        r = self.report
        self._drag = None
        asked = sorted(round(y - r.start, 1) for y in self._at)
        self._at = [float(y) for y in r.positions]  # as the report has them until the piece is nested again
        self.update()
        if asked != sorted(round(y - r.start, 1) for y in r.positions):
            self.moved.emit(r.name, asked)
        return asked

    def mousePressEvent(self, event) -> None:
        if event.button() == Qt.MouseButton.LeftButton and self.isEnabled():
            k = self._line_near(event.position())
            if k is not None:
                self._drag = k
                self.update()
                event.accept()
                return
        super().mousePressEvent(event)

    def mouseMoveEvent(self, event) -> None:
        if self._drag is not None:
            y = self._y_at(event.position().y())
            if y is not None:
                self._at[self._drag] = y
                self.update()
            event.accept()
            return
        if self._line_near(event.position()) is not None:
            self.setCursor(Qt.CursorShape.SizeVerCursor)
        else:
            self.unsetCursor()
        super().mouseMoveEvent(event)

    def mouseReleaseEvent(self, event) -> None:
        if self._drag is not None and event.button() == Qt.MouseButton.LeftButton:
            y = self._y_at(event.position().y())
            if y is not None:
                self._at[self._drag] = y
            self._release()
            event.accept()
            return
        super().mouseReleaseEvent(event)

    # ------------------------------------------------------------------ paint
    def paintEvent(self, _event) -> None:
        p = QPainter(self)
        try:
            p.setRenderHint(QPainter.RenderHint.Antialiasing)
            p.fillRect(self.rect(), self.palette().base())
            frame = self._frame()
            if frame is None:
                return
            self._paint_piece(p, frame)
        finally:
            p.end()

    def _paint_piece(self, p: QPainter, frame) -> None:
        r = self.report
        s, x0, y0, left, bottom = frame
        fm = QFontMetricsF(self.font())
        right = left + float(np.ptp(self.outline[:, 0])) * s
        top = bottom - r.width * s
        parts = self.parts()
        wide = [(k, hi - lo) for k, (lo, hi) in enumerate(parts) if hi - lo > self.usable + 1e-9]
        ink = self.palette().color(self.foregroundRole())

        # the title: the piece, or the part a splice there leaves too wide
        if wide:
            k, w = wide[0]
            title = f"{r.name}: part {k + 1} of {len(parts)} {w:.0f} mm, wider than the roll"
            p.setPen(QColor(PART_TOO_WIDE))
        else:
            title = f"{r.name}: {r.width:.0f} mm across; roll {self.usable:.0f} mm"
            p.setPen(ink)
        p.drawText(QRectF(self.MARGIN, self.MARGIN, self.width() - 2 * self.MARGIN, fm.height()),
                   Qt.AlignmentFlag.AlignLeft, fm.elidedText(title, Qt.TextElideMode.ElideRight,
                                                             self.width() - 2 * self.MARGIN))

        # the roll's usable width, from the edge of the part below the splice dragged (else the piece's)
        lo = y0
        if self._drag is not None:
            lo = parts[sorted(self._at).index(self._at[self._drag])][0]
        band_top = max(bottom - (lo + self.usable - y0) * s, top)
        band_bottom = min(bottom - (lo - y0) * s, bottom)
        if band_bottom > band_top:
            p.fillRect(QRectF(left - 4.0, band_top, right - left + 8.0, band_bottom - band_top), QColor("#e3eef9"))
            p.setPen(QPen(QColor("#7aa6d6"), 1.0, Qt.PenStyle.DashLine))
            p.drawLine(QPointF(left - 4.0, band_top), QPointF(right + 4.0, band_top))
            p.drawLine(QPointF(left - 4.0, band_bottom), QPointF(right + 4.0, band_bottom))

        # the piece's outline before splicing
        pixels = self.to_pixels(self.outline)
        p.setBrush(QBrush(QColor("#d5dde2")))
        p.setPen(QPen(QColor("#455a64"), 1.0))
        p.drawPolygon(QPolygonF([QPointF(x, y) for x, y in pixels]))

        # each splice: its overlap shaded, its line, its position from the edge
        half = 0.5 * self.overlap * s
        for k, y in enumerate(self._at):
            py = bottom - (y - y0) * s
            colour = QColor(SPLICE_DRAGGED if k == self._drag else SPLICE_LINE)
            shade = QColor(colour)
            shade.setAlpha(50)
            p.fillRect(QRectF(left, py - half, right - left, 2 * half), shade)
            p.setPen(QPen(colour, 2.0))
            p.drawLine(QPointF(left - 4.0, py), QPointF(right + 4.0, py))
            p.setPen(colour)
            p.drawText(QRectF(right + 18.0, py - fm.height() / 2, self.RIGHT - 18.0, fm.height()),
                       Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignVCenter, f"{_mm(y - y0)} mm")

        # each part's width across: a bracket beside the piece, red when wider than the roll
        for k, (a, b) in enumerate(parts):
            x = right + 8.0 + 4.0 * (k % 2)
            fits = b - a <= self.usable + 1e-9
            p.setPen(QPen(QColor(PART_FITS if fits else PART_TOO_WIDE), 2.0 if fits else 3.0))
            p.drawLine(QPointF(x, bottom - (a - y0) * s), QPointF(x, bottom - (b - y0) * s))


class CutPlanPanel(QWidget):
    """The Cut plan panel (see the module docstring). Signals: ``progress(material, marker)`` after
    each better marker is shown; each Nest ends with exactly one of ``finished(summary)`` and
    ``failed(message)``, one line each; ``input_error(message)`` a splice position refused (one line);
    ``splices_changed()`` when :meth:`piece_splices` may say otherwise (a Nest begun or ended, a document change);
    ``plan_edited(plan, label)`` a setting, a splice or a mirror pair edited: ``plan`` the project's cut plan
    (a :class:`flatweave.document.cutsettings.CutPlanSettings`) as asked, for the document to make one undoable
    edit called ``label`` (it comes back through :meth:`set_project`; the panel keeps no settings of its own,
    and one not taken is shown as the project has it)."""

    progress = Signal(str, object)
    finished = Signal(str)
    failed = Signal(str)
    input_error = Signal(str)
    splices_changed = Signal()
    plan_edited = Signal(object, str)
    # from the nesting thread to this one; the first argument is the Nest's number (a dropped one's is ignored)
    _planned = Signal(int, object)  # the pieces left out (names)
    _began = Signal(int, str)
    _better = Signal(int, str, object)
    _done = Signal(int, str, object, str)  # material, marker or None, its error ("" when none)
    _ended = Signal(int, object)  # None, or the Nest's one-line failure before any material

    def __init__(self, parent=None):
        super().__init__(parent)
        self.project: Project | None = None
        self.source: Project | None = None  # the project the markers shown were nested from
        self.markers: dict[str, Marker] = {}
        self.errors: dict[str, str] = {}  # a material's one-line failure (it has no marker)
        self.left_out: list[str] = []
        self.spliced: dict = {}  # per material, the pieces spliced (flatweave.document.cutplan.SpliceReport s)
        self._items: dict[str, PlanItem] = {}  # the last Nest's items before splicing, by name (to check a position)
        self._rows: list[SpliceReport] = []  # the splice table's rows
        self.workers: int | None = None  # the engine's threads (None: every core)
        self.last_summary: str | None = None  # how the last Nest ended, one line
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._run = 0  # the Nest's number: a run dropped (another document) is told apart by it
        self._now: str | None = None  # the material being nested
        self._stopped = False
        self._failed: str | None = None

        row = QHBoxLayout(self)
        row.setContentsMargins(4, 4, 4, 4)
        side = QWidget(self)
        side.setMaximumWidth(300)
        col = QVBoxLayout(side)
        col.setContentsMargins(0, 0, 0, 0)
        form = QFormLayout()
        form.setVerticalSpacing(3)
        self.material = QComboBox()
        self.material.setToolTip("The material whose marker is shown: pieces cut from different materials go "
                                 "on different rolls, a marker each")
        self.material.setSizeAdjustPolicy(QComboBox.SizeAdjustPolicy.AdjustToMinimumContentsLengthWithIcon)
        self.material.setMinimumContentsLength(10)
        self.material.currentIndexChanged.connect(self._material_chosen)
        form.addRow("Material", self.material)
        self.roll_width = QDoubleSpinBox(minimum=1.0, maximum=100_000.0, decimals=0, value=DEFAULT_ROLL_MM,
                                         suffix=" mm")
        self.roll_width.setKeyboardTracking(False)
        self.roll_width.setToolTip("The roll's width across, for the material shown: the materials table's "
                                   f"until typed ({DEFAULT_ROLL_MM:g} mm when the table gives none)")
        form.addRow("Roll width", self.roll_width)
        self.gap = QDoubleSpinBox(minimum=0.0, maximum=500.0, decimals=1, value=0.0, suffix=" mm")
        self.gap.setToolTip("The least distance kept between two pieces' cut outlines")
        form.addRow("Gap", self.gap)
        self.time_limit = QSpinBox(minimum=1, maximum=3600, value=int(DEFAULT_SECONDS), suffix=" s")
        self.time_limit.setToolTip("The time each material's marker may take at most (the engine may end "
                                   "sooner when it sees no more to gain); Stop ends it at any time")
        form.addRow("Time limit", self.time_limit)
        self.allowance = QDoubleSpinBox(minimum=0.0, maximum=MAX_ALLOWANCE_MM, decimals=1, value=0.0, suffix=" mm")
        self.allowance.setToolTip("The seam allowance added round each piece's cut outline (a seam's own "
                                  "allowance, set in the Seams list, along that seam)")
        form.addRow("Seam allowance", self.allowance)
        self.overlap = QDoubleSpinBox(minimum=0.0, maximum=500.0, decimals=1, value=25.0, suffix=" mm")
        self.overlap.setToolTip("A piece wider than the roll is spliced into the fewest parts that fit, by lines "
                                "along the roll through its least sheared cells; the parts overlap by this much "
                                "at each splice (a composite ply's 25 mm; a sewn seam's: twice its allowance)")
        form.addRow("Splice overlap", self.overlap)
        # each setting typed is an edit of the project's cut plan (on Enter or leaving the box, not each key)
        self._fields = {self.roll_width: (None, "Roll width"), self.gap: ("gap_mm", "Gap"),
                        self.time_limit: ("seconds", "Time limit"), self.allowance: ("allowance_mm", "Seam allowance"),
                        self.overlap: ("overlap_mm", "Splice overlap")}
        for box in self._fields:
            box.setKeyboardTracking(False)
            box.valueChanged.connect(lambda value, box=box: self._setting_typed(box, value))
        col.addLayout(form)
        self.mirror_title = QLabel("Mirror pairs")
        self.mirror_title.setToolTip(MIRROR_TIP)
        self.mirror_list = QListWidget()  # a checkable row per piece, in the pieces' order
        self.mirror_list.setToolTip(MIRROR_TIP)
        self.mirror_list.setMaximumHeight(110)
        self.mirror_list.setMinimumWidth(120)
        self.mirror_list.setMaximumWidth(180)
        self.mirror_list.setSelectionMode(QAbstractItemView.SelectionMode.NoSelection)
        self.mirror_list.itemChanged.connect(self._mirror_toggled)
        buttons = QHBoxLayout()
        self.nest_button = QPushButton("Nest")
        self.nest_button.setToolTip("Place every solved piece's copies on the roll, as short as the time allows "
                                    "(a marker per material), the window staying live")
        self.nest_button.clicked.connect(self.nest)
        self.stop_button = QPushButton("Stop")
        self.stop_button.setToolTip("End the nesting now, keeping the best marker so far")
        self.stop_button.clicked.connect(self.stop)
        buttons.addWidget(self.nest_button)
        buttons.addWidget(self.stop_button)
        buttons.addStretch(1)
        col.addLayout(buttons)
        numbers = QFormLayout()
        numbers.setVerticalSpacing(2)
        self.numbers: dict[str, QLabel] = {}
        for key, title in NUMBERS:
            label = QLabel("-")
            label.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
            label.setWordWrap(True)
            self.numbers[key] = label
            numbers.addRow(title, label)
        col.addLayout(numbers)
        self.state = QLabel()  # what the Nest is doing or how it ended, and whether the pieces changed since
        self.state.setWordWrap(True)
        col.addWidget(self.state)
        self.left_label = QLabel()
        self.left_label.setWordWrap(True)
        self.left_label.setStyleSheet(f"color: {STALE_COLOUR}")
        col.addWidget(self.left_label)
        self.splices = QTableWidget(0, len(SPLICE_COLUMNS))
        for c, (header, tip) in enumerate(SPLICE_COLUMNS):
            item = QTableWidgetItem(header)
            item.setToolTip(tip)
            self.splices.setHorizontalHeaderItem(c, item)
        self.splices.setEditTriggers(QAbstractItemView.EditTrigger.DoubleClicked
                                     | QAbstractItemView.EditTrigger.EditKeyPressed)
        self.splices.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        self.splices.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)  # a piece: the view's
        self.splices.verticalHeader().setVisible(False)
        self.splices.setWordWrap(False)
        self.splices.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        self.splices.horizontalHeader().setStretchLastSection(True)
        self.splices.setMaximumHeight(110)  # three rows: the roll above keeps the dock's height
        self.splices.setToolTip("The shown material's pieces spliced to fit the roll: double-click a piece's "
                                "Splices to type their positions across it, mm from its edge (700, or 700, 1400 "
                                "for three parts), or drag them in the view beside, and the pieces are nested "
                                "again; cleared, or Reset, the splices chosen through the least shear. Splices "
                                "placed by hand are saved with the project")
        self.splices.itemChanged.connect(self._splice_typed)
        self.splices.itemSelectionChanged.connect(self._show_splice_view)
        self.splice_view = SpliceView(self)
        self.splice_view.moved.connect(
            lambda name, mm: self.place_splices(name, ", ".join(str(v) for v in mm)))
        self.reset_splices_button = QPushButton("Reset splices")
        self.reset_splices_button.setToolTip("Forget the splices placed by hand on the shown material's pieces "
                                             "and nest again with the ones chosen")
        self.reset_splices_button.clicked.connect(lambda: self.reset_splices())
        self.splice_error = QLabel()  # the last splice position refused, one line
        self.splice_error.setWordWrap(True)
        self.splice_error.setStyleSheet(f"color: {END_COLOUR}")
        col.addStretch(1)
        row.addWidget(side)
        # the splices under the roll, which is long and thin and leaves the height: the side column is full
        right = QVBoxLayout()
        self.view = MarkerView(self)
        right.addWidget(self.view, 1)
        # under the roll: the mirror pairs, the splices (the table, the selected piece flat); then Reset and
        # the last splice refused, one line across
        under = QHBoxLayout()
        mirror = QVBoxLayout()
        mirror.setSpacing(2)
        mirror.addWidget(self.mirror_title)
        mirror.addWidget(self.mirror_list, 1)
        under.addLayout(mirror, 0)
        under.addWidget(self.splices, 1)
        under.addWidget(self.splice_view, 1)
        under.addStretch(0)  # the room the splices leave when there are none
        right.addLayout(under)
        buttons = QHBoxLayout()
        buttons.addWidget(self.reset_splices_button, 0, Qt.AlignmentFlag.AlignLeft)
        buttons.addWidget(self.splice_error, 1)
        buttons.addStretch(0)
        right.addLayout(buttons)
        row.addLayout(right, 1)

        self._planned.connect(self._on_planned)
        self._began.connect(self._on_began)
        self._better.connect(self._on_better)
        self._done.connect(self._on_done)
        self._ended.connect(self._on_ended)
        self._show()

    # ------------------------------------------------------------------ the document
    @property
    def busy(self) -> bool:
        return self._thread is not None

    @property
    def thread(self) -> threading.Thread | None:
        """The Nest's thread while one is on (it ends with the Nest's last signal)."""
        return self._thread

    @property
    def stale(self) -> bool:
        """The markers shown were nested from pieces, or with cut plan settings, that have changed since."""
        return self.source is not None and self.project is not None and (
            not same_pieces(self.source, self.project) or self.source.cut_plan != self.project.cut_plan)

    def set_project(self, project: Project | None, cause: str = "reset") -> None:
        """The document's project after a change (``cause`` as :class:`flatweave.document.history.Change`
        says): another document ("reset") drops the markers and stops a Nest; any other change leaves
        them shown, said stale when their pieces changed. The settings shown are ``project.cut_plan``'s."""
        self.project = project
        if cause == "reset" or project is None:
            self._stop.set()
            self._run += 1  # what the Nest under way still reports is dropped
            self.source, self.markers, self.errors, self.left_out = None, {}, {}, []
            self.spliced, self._items = {}, {}
            self._now, self._stopped, self._failed = None, False, None
            self.splice_error.clear()
        self._show()
        self.splices_changed.emit()  # stale now, or another piece active

    def materials(self) -> list[str]:
        """The material box's entries: the pieces' materials in order, then any other with a marker."""
        names = [] if self.project is None else [p.settings.material.name for p in self.project.pieces]
        return list(dict.fromkeys(names + list(self.markers) + list(self.errors)))

    def default_width(self, material: str) -> float:
        """``material``'s roll width in the materials table, else DEFAULT_ROLL_MM."""
        fabric = None if self.project is None else self.project.fabric(material)
        width = None if fabric is None else fabric.roll_width_mm
        return float(width) if width is not None else DEFAULT_ROLL_MM

    @property
    def plan(self) -> CutPlanSettings:
        """The project's cut plan (the settings as made with no project)."""
        return CutPlanSettings() if self.project is None else self.project.cut_plan

    def width_of(self, material: str) -> float:
        """The roll width a Nest uses for ``material`` (mm): the cut plan's, else the table's."""
        width = self.plan.width_for(material)
        return self.default_width(material) if width is None else width

    def set_roll_width(self, mm: float, material: str | None = None) -> bool:
        """Nest ``material`` (None: every material listed) on a roll ``mm`` wide (what the width box sets):
        one edit of the cut plan; True when the project's plan has it."""
        plan = self.plan
        try:
            for name in [material] if material is not None else self.materials():
                plan = plan.with_width(name, float(mm))
        except (FlatweaveError, TypeError, ValueError) as exc:
            self.input_error.emit(f"Roll width: {one_line(exc)}")
            self._show()
            return False
        return self._edit_plan(plan, "Roll width")

    def _edit_plan(self, plan: CutPlanSettings, label: str) -> bool:
        """Ask for ``plan`` (``plan_edited``), then show the project's plan as it is: the new one when the
        document took it, the old one when not. True when the project's plan is ``plan``."""
        if self.project is None:
            return False
        if plan != self.project.cut_plan:
            self.plan_edited.emit(plan, label)
        self._show()
        return self.project is not None and self.project.cut_plan == plan

    def _setting_typed(self, box, value) -> None:
        """A setting's box edited: that setting of the cut plan (the roll width: the shown material's)."""
        if self.project is None:
            return
        field, label = self._fields[box]
        plan = self.plan
        try:
            if field is None:
                name = self.shown_material()
                if name is None or float(value) == self.width_of(name):
                    return
                plan = plan.with_width(name, float(value))
            else:
                plan = replace(plan, **{field: float(value)})
        except (FlatweaveError, TypeError, ValueError) as exc:
            self.input_error.emit(f"{label}: {one_line(exc)}")
            self._show()
            return
        self._edit_plan(plan, label)

    def _mirror_toggled(self, row: QListWidgetItem) -> None:
        name = row.data(Qt.ItemDataRole.UserRole)
        on = row.checkState() == Qt.CheckState.Checked
        if self.project is None or name is None or on == self.plan.mirrored(name):
            return
        self._edit_plan(self.plan.with_mirror(name, on), "Mirror pairs")

    def set_mirror(self, piece: str, on: bool) -> bool:
        """Cut piece ``piece`` in mirror pairs (``on``) or all as drawn, as its row's box does."""
        for k in range(self.mirror_list.count()):
            row = self.mirror_list.item(k)
            if row.data(Qt.ItemDataRole.UserRole) == piece:
                row.setCheckState(Qt.CheckState.Checked if on else Qt.CheckState.Unchecked)
                return self.plan.mirrored(piece) == bool(on)
        return False

    def mirror_rows(self) -> list[tuple[str, bool]]:
        """The mirror pairs list: each row's piece and whether it is checked."""
        return [(self.mirror_list.item(k).data(Qt.ItemDataRole.UserRole),
                 self.mirror_list.item(k).checkState() == Qt.CheckState.Checked)
                for k in range(self.mirror_list.count())]

    def _material_of(self, name: str) -> str | None:
        """The material of item ``name`` (a piece's name, numbered "NAME K" when its pattern has several)."""
        if name in self._items:
            return self._items[name].material
        if self.project is None:
            return None
        for piece in self.project.pieces:
            if name == piece.name:
                return piece.settings.material.name
        for piece in self.project.pieces:
            if re.fullmatch(re.escape(piece.name) + r" \d+", name):
                return piece.settings.material.name
        return None

    def shown_material(self) -> str | None:
        return self.material.currentData()

    def choose_material(self, name: str) -> None:
        """Show ``name``'s marker and roll width (what the material box asks)."""
        k = self.material.findData(name)
        if k >= 0:
            self.material.setCurrentIndex(k)

    def _material_chosen(self, _index: int) -> None:
        self._show()

    def number(self, key: str) -> str:
        """The text of number ``key`` (a key of NUMBERS) as shown."""
        return self.numbers[key].text()

    # ------------------------------------------------------------------ nesting
    def nest(self) -> bool:
        """Nest the document's solved pieces, a marker per material, in a thread (see the module
        docstring); False when a Nest is on already or there is no document."""
        if self.busy or self.project is None:
            return False
        source = self.project
        plan = source.cut_plan  # the project's: what it was nested with
        widths = {name: self.width_of(name) for name in self.materials()}
        gap, seconds, allowance, overlap = plan.gap_mm, plan.seconds, plan.allowance_mm, plan.overlap_mm
        placed, rotations = plan.splice_map(), plan.rotations
        self._stop.clear()
        self._run += 1
        run, stop, workers = self._run, self._stop, self.workers
        self.source, self.markers, self.errors, self.left_out = source, {}, {}, []
        self.spliced, self._items = {}, {}
        self._now, self._stopped, self._failed = None, False, None
        self.splice_error.clear()

        def work():
            try:
                items, left = project_items(source, source.name, allowance, rotations=rotations)
                self._items = {it.item.name: it for it in items}
                groups = by_material(items)
                self._planned.emit(run, left)
                if not items:
                    raise SettingsError("no piece is solved: nothing to nest (Solve all first)")
                for material, group in groups.items():
                    if stop.is_set():
                        break
                    self._began.emit(run, material)
                    width = widths.get(material, DEFAULT_ROLL_MM)
                    try:
                        # a piece wider than the roll: spliced into the fewest parts that fit, as nest does
                        # the hand-placed splices of this material's pieces (a piece renamed or gone is not)
                        names = {g.item.name for g in group}
                        group, spliced = splice_items(group, width, overlap,
                                                      {n: mm for n, mm in placed.items() if n in names})
                        self.spliced[material] = spliced
                        marker = nest([g.item for g in group], width, gap, seconds,
                                      workers=workers, stop=stop,
                                      on_progress=lambda m, material=material: self._better.emit(run, material, m))
                        error = ""
                    except FlatweaveError as exc:  # stopped before a marker was found: not nested, no error
                        marker, error = None, "" if stop.is_set() else one_line(exc)
                    self._done.emit(run, material, marker, error)
                outcome = None
            except FlatweaveError as exc:
                outcome = one_line(exc)
            except Exception as exc:  # a bug must not end the thread silently: it is said in one line
                traceback.print_exc(file=sys.stderr)
                outcome = f"internal error: {one_line(exc)}"
            self._ended.emit(run, outcome)

        self._thread = threading.Thread(target=work, name="flatweave-nest", daemon=True)
        self._thread.start()
        self._show()
        self.splices_changed.emit()  # the last markers' are gone
        return True

    def stop(self) -> None:
        """End the Nest under way at once: the best marker so far stays; materials not reached are not nested."""
        if self.busy and not self._stop.is_set():
            self._stop.set()
            self._stopped = True
            self._show()

    def shutdown(self) -> None:
        """Stop a Nest and wait for its thread (the window is closing)."""
        self._stop.set()
        self._run += 1
        thread, self._thread = self._thread, None
        if thread is not None:
            thread.join()

    def _on_planned(self, run: int, left) -> None:
        if run == self._run:
            self.left_out = list(left)
            self._show()

    def _on_began(self, run: int, material: str) -> None:
        if run == self._run:
            self._now = material
            self._show()
            self.choose_material(material)  # the marker being made is the one shown, live

    def _on_better(self, run: int, material: str, marker: Marker) -> None:
        if run != self._run:
            return
        self.markers[material] = marker
        self._show()
        self.progress.emit(material, marker)

    def _on_done(self, run: int, material: str, marker: Marker | None, error: str) -> None:
        if run != self._run:
            return
        if marker is not None:
            self.markers[material] = marker
            self._stopped = self._stopped or marker.stopped
        else:
            self.markers.pop(material, None)
            if error:
                self.errors[material] = error
        self._show()

    def _on_ended(self, run: int, outcome) -> None:
        thread, self._thread = self._thread, None
        if thread is not None:
            thread.join()
        self._now = None
        if run != self._run:  # dropped (another document, the window closing): said, nothing shown
            self._show()
            self.splices_changed.emit()
            self.finished.emit("Nest dropped: its document is no longer shown")
            return
        if outcome is None and self.errors:  # the materials nested keep their markers
            outcome = "; ".join(f"{m}: {e}" for m, e in self.errors.items())
        self._failed = outcome
        self._show()
        self.splices_changed.emit()
        if outcome is not None:
            self.last_summary = " ".join(outcome.split())
            self.failed.emit(self.last_summary)
            return
        parts = [f"{m} {_length_m(k.length)} ({100 * k.utilisation:.1f} %)" for m, k in self.markers.items()]
        summary = "Cut plan: " + "; ".join(parts) if parts else "Cut plan: nothing nested"
        if self._stopped:
            summary += f" ({STOPPED})"
        if self.left_out:
            summary += f"; left out (not solved): {', '.join(self.left_out)}"
        spliced = [r for reports in self.spliced.values() for r in reports]
        if spliced:
            summary += f"; spliced (wider than the roll): {', '.join(f'{r.name} in {len(r.parts)}' for r in spliced)}"
        self.last_summary = " ".join(summary.split())
        self.finished.emit(self.last_summary)

    # ------------------------------------------------------------------ splices
    def piece_splices(self) -> list[SpliceReport]:
        """The splices of the document's active piece in the markers shown (a report per pattern piece
        spliced, any material): none while nesting, with no marker, or when the markers are stale."""
        if self.project is None or self.source is None or self.busy or self.stale:
            return []
        tail = f"#{self.project.piece_name}"
        return [r for material, reports in self.spliced.items() if material in self.markers
                for r in reports if r.source.endswith(tail)]

    def splice_rows(self) -> list[tuple[str, ...]]:
        """The splice table's cells' texts, row by row."""
        return [tuple(self.splices.item(r, c).text() for c in range(self.splices.columnCount()))
                for r in range(self.splices.rowCount())]

    def place_splices(self, name: str, text: str) -> bool:
        """Splice the piece ``name`` (an item's name, as the table's rows) at the positions ``text``
        (:func:`read_splices`; empty: the chosen ones), kept in the project's cut plan (one edit, asked by
        ``plan_edited``), and nest again. A position its piece cannot take (checked now, on the roll width
        and overlap the Nest will use) is ``input_error``, one line, and nothing else changes; so is a Nest
        under way. True when a Nest started."""
        item = self._items.get(name)
        plan = self.plan
        try:
            if self.busy:
                raise SettingsError("wait for the Nest under way to end (or Stop it)")
            if item is None:
                raise SettingsError("no piece to nest is named so (Nest again)")
            mm = read_splices(text)
            if not mm and name not in plan.splice_map():  # cleared, and the chosen ones are shown: nothing to do
                self._show_splices(force=True)
                return False
            if mm:
                splice_items([item], self.width_of(item.material), plan.overlap_mm, {name: mm})
            plan = plan.with_splices(name, mm or None)
        except (FlatweaveError, ValueError) as exc:
            message = f"Splices of {name}: {one_line(exc)}"
            self.splice_error.setText(message)
            self._show_splices(force=True)  # the cell as it was
            self.input_error.emit(message)
            return False
        self.splice_error.clear()
        if not self._edit_plan(plan, "Splices"):  # not taken (the document said why): the cell as it was
            self._show_splices(force=True)
            return False
        return self.nest()

    def reset_splices(self, material: str | None = None) -> bool:
        """Forget the splices placed by hand on ``material``'s pieces (None: the shown material's), one edit
        of the cut plan, and nest again; True when a Nest started (False: none was placed, or a Nest is on)."""
        material = self.shown_material() if material is None else material
        names = [n for n in self.plan.splice_map() if self._material_of(n) == material]
        if not names or self.busy:
            return False
        plan = self.plan
        for n in names:
            plan = plan.with_splices(n, None)
        if not self._edit_plan(plan, "Reset splices"):
            return False
        return self.nest()

    def _splice_typed(self, item: QTableWidgetItem) -> None:
        r = item.row()
        if item.column() != SPLICES or not 0 <= r < len(self._rows):
            return
        report = self._rows[r]
        if item.text().strip() == self._positions_text(report):
            return  # not changed (an editor opened and closed)
        self.place_splices(report.name, item.text())

    @staticmethod
    def _positions_text(report: SpliceReport) -> str:
        return ", ".join(_mm(y - report.start) for y in report.positions)

    def _show_splices(self, force: bool = False) -> None:
        """The splice table: the shown material's spliced pieces (refilled when they change, or ``force``)."""
        name = self.shown_material()
        rows = list(self.spliced.get(name, [])) if name is not None else []
        placed = name is not None and any(self._material_of(n) == name for n in self.plan.splice_map())
        self.reset_splices_button.setEnabled(placed and not self.busy)
        self.splices.setEnabled(not self.busy)
        self.splice_view.setEnabled(not self.busy)
        self.splices.setVisible(bool(rows))
        self.splice_view.setVisible(bool(rows))
        self.reset_splices_button.setVisible(bool(rows) or placed)
        self.splice_error.setVisible(bool(self.splice_error.text()))
        if rows == self._rows and not force:
            self._show_splice_view()
            return  # an editor open in it stays open
        viewed = self.splice_view.report.name if self.splice_view.report is not None else None
        self._rows = rows
        fixed = Qt.ItemFlag.ItemIsSelectable | Qt.ItemFlag.ItemIsEnabled
        with QSignalBlocker(self.splices):
            self.splices.clearContents()
            self.splices.setRowCount(len(rows))
            for r, report in enumerate(rows):
                cells = (report.name, f"{_mm(report.width)} mm", self._positions_text(report),
                         "by hand" if report.asked else "chosen")
                for c, text in enumerate(cells):
                    cell = QTableWidgetItem(text)
                    cell.setFlags(fixed | Qt.ItemFlag.ItemIsEditable if c == SPLICES else fixed)
                    cell.setToolTip(SPLICE_COLUMNS[c][1])
                    if c in (1, SPLICES):
                        cell.setTextAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
                    self.splices.setItem(r, c, cell)
            # the piece viewed stays selected when it is still spliced
            for r, report in enumerate(rows):
                if report.name == viewed:
                    self.splices.selectRow(r)
        self._show_splice_view(force=force)

    def selected_splice_row(self) -> int:
        """The splice table's selected row (the first when none is; -1 when the table is empty)."""
        chosen = self.splices.selectionModel().selectedIndexes()
        return chosen[0].row() if chosen else (0 if self._rows else -1)

    def _show_splice_view(self, force: bool = False) -> None:
        """The splice view: the selected row's piece (the first row's when none is selected)."""
        r = self.selected_splice_row()
        report = self._rows[r] if 0 <= r < len(self._rows) else None
        item = None if report is None else self._items.get(report.name)
        if report is None or item is None:
            self.splice_view.set_piece(None)
            return
        if force:
            self.splice_view.set_piece(None)  # drawn again from the report: a refused drag snaps back
        self.splice_view.set_piece(report, item.item.outline, usable_width(self.width_of(item.material)),
                                   self.plan.overlap_mm)

    # ------------------------------------------------------------------ shown
    def _show(self) -> None:
        """The material box, the width, the marker, its numbers and the state, for what is known now."""
        names = self.materials()
        with QSignalBlocker(self.material):
            current = self.material.currentData()
            self.material.clear()
            for name in names:
                self.material.addItem(name, name)
            self.material.setCurrentIndex(max(0, self.material.findData(current)))
        name = self.shown_material()
        self._show_plan(name)
        busy, has = self.busy, self.project is not None
        self.nest_button.setEnabled(has and not busy)
        self.stop_button.setEnabled(busy and not self._stop.is_set())
        self.material.setEnabled(has)
        for w in (self.roll_width, self.gap, self.time_limit, self.allowance, self.overlap, self.mirror_list):
            w.setEnabled(has and not busy)  # a Nest under way keeps the values it started with

        marker = self.markers.get(name) if name is not None else None
        self.view.set_marker(marker, self._message(name))
        self.view.set_stale(self.stale)
        self._show_numbers(marker, name)
        self.state.setText(self._state_text())
        self.state.setStyleSheet(f"color: {STALE_COLOUR}" if self.stale or self._failed else "")
        spliced = self.spliced.get(name, []) if name is not None else []
        lines = ([f"Left out (not solved, or solved before a change): {', '.join(self.left_out)}"]
                 if self.left_out else [])
        lines += ([f"Spliced, wider than the roll: {', '.join(f'{r.name} in {len(r.parts)} parts' for r in spliced)}"]
                  if spliced else [])
        self.left_label.setText("\n".join(lines))
        self.left_label.setVisible(bool(lines))
        self._show_splices()

    def _show_plan(self, name: str | None) -> None:
        """The settings' boxes and the mirror pairs list as the project's cut plan has them (their signals
        blocked: showing is no edit); a box already showing its value is left alone (an edit in it stays)."""
        plan = self.plan
        values = {self.roll_width: self.width_of(name) if name is not None else DEFAULT_ROLL_MM,
                  self.gap: plan.gap_mm, self.time_limit: max(1, round(plan.seconds)),
                  self.allowance: plan.allowance_mm, self.overlap: plan.overlap_mm}
        for box, value in values.items():
            shown = box.valueFromText(box.textFromValue(value))  # as the box rounds it
            if box.value() != shown:
                with QSignalBlocker(box):
                    box.setValue(value)
        names = [] if self.project is None else [p.name for p in self.project.pieces]
        with QSignalBlocker(self.mirror_list):
            if [row for row, _ in self.mirror_rows()] != names:
                self.mirror_list.clear()
                for piece in names:
                    row = QListWidgetItem(piece)
                    row.setData(Qt.ItemDataRole.UserRole, piece)
                    row.setFlags(Qt.ItemFlag.ItemIsEnabled | Qt.ItemFlag.ItemIsUserCheckable)
                    row.setToolTip(f"{piece}: {MIRROR_TIP[0].lower()}{MIRROR_TIP[1:]}")
                    row.setCheckState(Qt.CheckState.Unchecked)  # shows its box
                    self.mirror_list.addItem(row)
            for k, piece in enumerate(names):
                state = Qt.CheckState.Checked if plan.mirrored(piece) else Qt.CheckState.Unchecked
                if self.mirror_list.item(k).checkState() != state:
                    self.mirror_list.item(k).setCheckState(state)

    def _message(self, name: str | None) -> str:
        """What the view says with no marker of ``name`` to draw."""
        if self.project is None:
            return "No document"
        if name is not None and name in self.errors:
            return f"No marker: {self.errors[name]}"
        if self._failed:
            return f"No marker: {self._failed}"
        if self.busy:
            return f"Nesting {name}..." if name == self._now else f"{name}: waiting to be nested"
        if self.source is not None and name is not None:
            return f"{name}: not nested" + (" (stopped)" if self._stopped else "")
        return "Nest places the solved pieces' cut outlines on the roll, as short as it can in the time given"

    def _show_numbers(self, marker: Marker | None, name: str | None) -> None:
        if marker is None:
            for label in self.numbers.values():
                label.setText("-")
            return
        asked = sum(it.quantity for it in marker.items)
        live = self.busy and name == self._now and not marker.stopped
        self.numbers["length"].setText(f"{_length_m(marker.length)} on a {marker.roll_width:g} mm roll")
        self.numbers["utilisation"].setText(f"{100 * marker.utilisation:.2f} %")
        self.numbers["waste"].setText(f"{marker.waste / 1e6:.3f} m\u00b2")
        self.numbers["placed"].setText(f"{len(marker.placements)} of {asked} copies"
                                       f" ({len(marker.items)} piece{'s' if len(marker.items) != 1 else ''})")
        self.numbers["time"].setText(f"{marker.seconds:.1f} s" + (", nesting on..." if live else
                                                                  f" ({STOPPED})" if marker.stopped else ""))

    def _state_text(self) -> str:
        if self.project is None:
            return ""
        if self.busy:
            if self._stop.is_set():
                text = "Stopping..."
            else:
                text = f"Nesting {self._now}..." if self._now else "Preparing the pieces' cut outlines..."
        elif self._failed:
            text = self._failed
        elif self.source is None:
            text = ""
        elif self._stopped:
            text = STOPPED[0].upper() + STOPPED[1:]
        else:
            text = f"Nested {len(self.markers)} material{'s' if len(self.markers) != 1 else ''}"
        if self.stale:
            text = f"{STALE[0].upper()}{STALE[1:]}" + (f". {text}" if text else "")
        return text
