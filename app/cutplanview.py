"""The Cut plan panel (issue 43): the document's solved pieces nested on the roll, a marker per
material (:func:`flatweave.document.cutplan.project_items`, grouped by
:func:`flatweave.document.cutplan.by_material`, each group placed by
:func:`flatweave.studies.nesting.nest`), drawn by :class:`MarkerView`: the roll along x, each
placed copy's cut outline filled in its item's colour and named when the name fits inside it, a
legend of the items, the marker's end and a scale along the roll. Beside it the chosen
material's numbers: length (m), utilisation (%), waste (m^2), copies placed and the time.

Its controls: the material shown (a marker each), that material's roll width (mm; the
materials table's ``roll_width_mm`` until typed, else :data:`DEFAULT_ROLL_MM`), and for every
material the gap, the time limit (per material) and the seam allowance; Nest and Stop. Nest
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
at once (a refused one is ``input_error(message)``, one line, and nothing else changes) and re-nests with it;
a cleared cell or Reset goes back to the chosen splices. Splices placed by hand last for the session (not
saved in the project). :meth:`CutPlanPanel.piece_splices` gives the document's active piece's splices in the
markers shown (none when stale), which the window draws on the surface; ``splices_changed`` says when
they may have changed. :meth:`CutPlanPanel.shutdown` (the window's close) stops a nest and waits for its
thread. No VTK here."""

from __future__ import annotations

import math
import sys
import threading
import traceback

import numpy as np
from PySide6.QtCore import QPointF, QRectF, QSignalBlocker, QSize, Qt, Signal
from PySide6.QtGui import QBrush, QColor, QFont, QFontMetricsF, QPainter, QPen, QPolygonF
from PySide6.QtWidgets import (QAbstractItemView, QComboBox, QDoubleSpinBox, QFormLayout, QHBoxLayout, QHeaderView,
                               QLabel, QPushButton, QSizePolicy, QSpinBox, QTableWidget, QTableWidgetItem, QVBoxLayout,
                               QWidget)
from shapely.geometry import Polygon
from shapely.ops import polylabel

from flatweave.app.worker import one_line
from flatweave.document.cutplan import PlanItem, SpliceReport, by_material, project_items, splice_items
from flatweave.document.project import Project
from flatweave.document.sewing import MAX_ALLOWANCE_MM
from flatweave.errors import FlatweaveError, SettingsError
from flatweave.studies.nesting import DEFAULT_SECONDS, Marker, nest

__all__ = ["CutPlanPanel", "MarkerView", "piece_colour", "same_pieces", "read_splices", "DEFAULT_ROLL_MM", "STOPPED",
           "STALE", "NUMBERS", "SPLICE_COLUMNS"]

DEFAULT_ROLL_MM = 1500.0  # a material the table gives no roll width
STOPPED = "stopped: the best so far"
STALE = "pieces changed since: Nest again"
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
    item, named when the name fits, a legend above, the marker's end (a red line and its length) and
    a scale along the roll below. ``message`` is drawn when there is no marker; a ``stale`` marker is
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
            p.setPen(QPen(colour.darker(160), 1.0))
            p.drawPolygon(QPolygonF([QPointF(x, y) for x, y in pixels]))
            w, h = fm.horizontalAdvance(name), fm.height()
            if w <= 2.0 * room * s and h <= room * s:  # the name fits inside the piece
                at = self.to_pixels([(lx, ly)])[0]
                p.setPen(QColor("#111111"))
                p.drawText(QRectF(at[0] - w / 2 - 2, at[1] - h / 2, w + 4, h), Qt.AlignmentFlag.AlignCenter, name)
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


class CutPlanPanel(QWidget):
    """The Cut plan panel (see the module docstring). Signals: ``progress(material, marker)`` after
    each better marker is shown; each Nest ends with exactly one of ``finished(summary)`` and
    ``failed(message)``, one line each; ``input_error(message)`` a splice position refused (one line);
    ``splices_changed()`` when :meth:`piece_splices` may say otherwise (a Nest begun or ended, a document change)."""

    progress = Signal(str, object)
    finished = Signal(str)
    failed = Signal(str)
    input_error = Signal(str)
    splices_changed = Signal()
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
        # the splices placed by hand, mm from each piece's edge by item name: every Nest's, for the session
        self.placed: dict[str, list[float]] = {}
        self._items: dict[str, PlanItem] = {}  # the last Nest's items before splicing, by name (to check a position)
        self._rows: list[SpliceReport] = []  # the splice table's rows
        self.workers: int | None = None  # the engine's threads (None: every core)
        self.last_summary: str | None = None  # how the last Nest ended, one line
        self._widths: dict[str, float] = {}  # roll widths typed, by material (the others: the table's)
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
        self.roll_width.valueChanged.connect(self._width_typed)
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
        col.addLayout(form)
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
        self.splices.verticalHeader().setVisible(False)
        self.splices.setWordWrap(False)
        self.splices.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        self.splices.horizontalHeader().setStretchLastSection(True)
        self.splices.setMaximumHeight(110)  # three rows: the roll above keeps the dock's height
        self.splices.setToolTip("The shown material's pieces spliced to fit the roll: double-click a piece's "
                                "Splices to type their positions across it, mm from its edge (700, or 700, 1400 "
                                "for three parts), and the pieces are nested again; cleared, or Reset, the "
                                "splices chosen through the least shear. Splices placed by hand last for this "
                                "session: they are not saved in the project")
        self.splices.itemChanged.connect(self._splice_typed)
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
        under = QHBoxLayout()
        under.addWidget(self.splices, 1)
        buttons = QVBoxLayout()
        buttons.addWidget(self.reset_splices_button, 0, Qt.AlignmentFlag.AlignLeft)
        buttons.addWidget(self.splice_error)
        buttons.addStretch(1)
        under.addLayout(buttons, 1)
        right.addLayout(under)
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
        """The markers shown were nested from pieces that have changed since."""
        return self.source is not None and self.project is not None and not same_pieces(self.source, self.project)

    def set_project(self, project: Project | None, cause: str = "reset") -> None:
        """The document's project after a change (``cause`` as :class:`flatweave.document.history.Change`
        says): another document ("reset") drops the markers and stops a Nest; any other change leaves
        them shown, said stale when their pieces changed."""
        self.project = project
        if cause == "reset" or project is None:
            self._stop.set()
            self._run += 1  # what the Nest under way still reports is dropped
            self.source, self.markers, self.errors, self.left_out, self._widths = None, {}, {}, [], {}
            self.spliced, self.placed, self._items = {}, {}, {}
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

    def width_of(self, material: str) -> float:
        """The roll width a Nest uses for ``material`` (mm): typed, else the table's."""
        return self._widths.get(material, self.default_width(material))

    def set_roll_width(self, mm: float, material: str | None = None) -> None:
        """Nest ``material`` (None: every material listed) on a roll ``mm`` wide (what the width box sets)."""
        for name in [material] if material is not None else self.materials():
            self._widths[name] = float(mm)
        self._show()

    def shown_material(self) -> str | None:
        return self.material.currentData()

    def choose_material(self, name: str) -> None:
        """Show ``name``'s marker and roll width (what the material box asks)."""
        k = self.material.findData(name)
        if k >= 0:
            self.material.setCurrentIndex(k)

    def _material_chosen(self, _index: int) -> None:
        self._show()

    def _width_typed(self, value: float) -> None:
        name = self.shown_material()
        if name is not None and value != self.width_of(name):
            self._widths[name] = float(value)

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
        widths = {name: self.width_of(name) for name in self.materials()}
        gap, seconds, allowance = float(self.gap.value()), float(self.time_limit.value()), float(self.allowance.value())
        overlap = float(self.overlap.value())
        placed = {name: list(mm) for name, mm in self.placed.items()}
        self._stop.clear()
        self._run += 1
        run, stop, workers = self._run, self._stop, self.workers
        self.source, self.markers, self.errors, self.left_out = source, {}, {}, []
        self.spliced, self._items = {}, {}
        self._now, self._stopped, self._failed = None, False, None
        self.splice_error.clear()

        def work():
            try:
                items, left = project_items(source, source.name, allowance)
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
        (:func:`read_splices`; empty: the chosen ones) and nest again. A position its piece cannot take
        (checked now, on the roll width and overlap the Nest will use) is ``input_error``, one line, and
        nothing else changes; so is a Nest under way. True when a Nest started."""
        item = self._items.get(name)
        try:
            if self.busy:
                raise SettingsError("wait for the Nest under way to end (or Stop it)")
            if item is None:
                raise SettingsError("no piece to nest is named so (Nest again)")
            mm = read_splices(text)
            if not mm and name not in self.placed:  # cleared, and the chosen ones are shown: nothing to do
                self._show_splices(force=True)
                return False
            if mm:
                splice_items([item], self.width_of(item.material), float(self.overlap.value()), {name: mm})
        except (FlatweaveError, ValueError) as exc:
            message = f"Splices of {name}: {one_line(exc)}"
            self.splice_error.setText(message)
            self._show_splices(force=True)  # the cell as it was
            self.input_error.emit(message)
            return False
        if mm:
            self.placed[name] = mm
        else:
            self.placed.pop(name, None)
        return self.nest()

    def reset_splices(self, material: str | None = None) -> bool:
        """Forget the splices placed by hand on ``material``'s pieces (None: the shown material's) and
        nest again; True when a Nest started (False: none was placed, or a Nest is on)."""
        material = self.shown_material() if material is None else material
        names = [n for n, it in self._items.items() if it.material == material and n in self.placed]
        if not names or self.busy:
            return False
        for n in names:
            del self.placed[n]
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
        placed = any(it.material == name and n in self.placed for n, it in self._items.items())
        self.reset_splices_button.setEnabled(placed and not self.busy)
        self.splices.setEnabled(not self.busy)
        self.splices.setVisible(bool(rows))
        self.reset_splices_button.setVisible(bool(rows) or placed)
        if rows == self._rows and not force:
            return  # an editor open in it stays open
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
        with QSignalBlocker(self.roll_width):
            self.roll_width.setValue(self.width_of(name) if name is not None else DEFAULT_ROLL_MM)
        busy, has = self.busy, self.project is not None
        self.nest_button.setEnabled(has and not busy)
        self.stop_button.setEnabled(busy and not self._stop.is_set())
        self.material.setEnabled(has)
        for w in (self.roll_width, self.gap, self.time_limit, self.allowance, self.overlap):
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
        self.splice_error.setVisible(bool(self.splice_error.text()))

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
