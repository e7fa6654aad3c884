"""The ply book (issue 41, item 5): the PDF a project's pieces go to the shop
floor with, and the stacking table it opens with.

Pages, in order:

1. the cover: the project, its source and units, the date, and the stacking
   table (a row per piece in laying order: sequence, name, quantity,
   material, orientation, flat size, flat area, largest shear, the share of
   the area sheared beyond the material's lock angle, status and the count of
   warnings), continued on further pages when it is long, then the project's
   consistency warnings (:func:`flatweave.document.checks.project_checks`);
2. a page per piece, in the same order: a picture of the tool (an orthographic
   three-quarter view) with the piece filled, the other pieces faint, its weft
   and warp threads and the fibre directions at its seed as arrows; its
   numbers; its warnings; and its flat pattern drawn at a stated scale
   (:data:`BOOK_SCALES`, the largest that fits, never enlarged), with a scale
   bar, its grain line, its name, its darts and its overall dimensions in mm;
3. a page per marker given (``markers``: the cut plan's nesting, issue 43): its
   material, the roll's width, the marker's length, utilisation and waste, the
   whole marker drawn at a round scale (:func:`flatweave.export.marker.draw_marker`)
   with a scale bar, and a table of the pieces on it (name, copies, source),
   continued on further pages when it is long.

A piece not solved, or whose result no longer matches its settings (stale),
has its row and page say so; its pattern is drawn only from a current result.
The book is written in one piece (:func:`write_ply_book`: atomically), after
everything in it was drawn.
"""

from __future__ import annotations

import datetime as _dt
import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flatweave.document.checks import project_checks, seam_rows
from flatweave.document.project import settings_equal
from flatweave.errors import SettingsError
from flatweave.document.rosettes import orientation_text
from flatweave.export.pdf import (MM, ROUND_SCALES, draw_scale_bar, draw_sheet, nice_length, paper_size,
                                  round_scale, scale_text)
from flatweave.document.sewing import piece_sheet
from flatweave.export.marker import draw_marker, marker_scale, placed_sheet
from flatweave.export.sheet import mm_per_unit
from flatweave.files import atomic_write_bytes
from flatweave.geometry.numerics import polygon_area
from flatweave.method.lattice import WARP, WEFT
from flatweave.method.materials import fabric_kind
from flatweave.method.rosette import rosette, rosette_arrows
from flatweave.version import __version__

__all__ = ["BOOK_SCALES", "BookRow", "book_rows", "book_order", "plybook_bytes", "write_ply_book",
           "pattern_box", "book_scale"]

BOOK_SCALES = ROUND_SCALES  # 1:k, then the same times powers of ten
MARGIN = 12.0  # mm round the page's content
ROW_MM = 5.0  # the stacking table's row pitch
DIM_MM = 9.0  # room for the dimension lines beside the pattern
WEFT_RGB = (0.80, 0.18, 0.18)
WARP_RGB = (0.13, 0.33, 0.80)
PIECE_RGB = (0.98, 0.83, 0.55)
THREADS = 14  # weft and warp threads drawn across a piece on the tool, about


@dataclass(frozen=True)
class BookRow:
    """One row of the stacking table: a piece as the shop reads it.

    orientation : its text (:func:`flatweave.document.rosettes.orientation_text`)
    size_mm : (width, height) of its flat sew line(s), mm; None when not drawn
    area_m2 : its flat area (sew lines, darts taken out), m^2; None when not drawn
    status : "not solved", "stale (settings changed)", or the result's status
    """

    sequence: int | None
    name: str
    quantity: int
    material: str
    orientation: str
    size_mm: tuple | None
    area_m2: float | None
    max_shear_deg: float | None
    beyond_lock_pct: float | None
    status: str
    warnings: tuple
    orientation_short: str = ""  # the table's column: "+45" from a rosette, "w+12.5" a weft angle alone


def book_order(project) -> list:
    """The project's pieces in laying order: by sequence, the pieces without one after, each group
    in the project's order."""
    pieces = list(project.pieces)
    return sorted(pieces, key=lambda p: (p.sequence is None, p.sequence or 0, pieces.index(p)))


def _current(piece):
    """The piece's result if it matches its settings, else None."""
    r = piece.result
    return r if r is not None and settings_equal(r.settings, piece.settings) else None


def book_rows(project, seam_allowance_mm: float = 0.0) -> list[BookRow]:
    """The stacking table's rows, in :func:`book_order`."""
    return [_row(p, _sheet(project, p, seam_allowance_mm)) for p in book_order(project)]


def _sheet(project, piece, seam_allowance_mm):
    r = _current(piece)
    if r is None or not r.pattern.pieces:
        return None
    return piece_sheet(project, piece.name, seam_allowance_mm)


def _row(piece, sheet) -> BookRow:
    s = piece.settings
    r = _current(piece)
    status = "not solved" if piece.result is None else "stale (settings changed)" if r is None else r.status
    size = area = shear = lock = None
    warnings = tuple(r.warnings) if r is not None else ()
    if sheet is not None:
        lo = np.min([p.sew.min(axis=0) for p in sheet.pieces], axis=0)
        hi = np.max([p.sew.max(axis=0) for p in sheet.pieces], axis=0)
        size = tuple(float(v) for v in hi - lo)
        area = sum(polygon_area(p.sew) - sum(abs(polygon_area(h)) for h in p.holes) for p in sheet.pieces) * 1e-6
        shear = float(r.metrics.get("max_shear_deg", math.nan))
        lock = float(r.metrics.get("area_beyond_lock_pct", math.nan))
    return BookRow(piece.sequence, piece.name, piece.quantity, s.material.name or "custom",
                   orientation_text(piece), size, area, shear, lock, status, warnings,
                   orientation_text(piece, short=True))


# ---------------------------------------------------------------------- layout
def pattern_box(paper: str = "a4") -> tuple[float, float, float, float]:
    """(x, y, width, height), mm from the page's bottom-left: where a piece's page draws its flat
    pattern, its dimension lines included."""
    pw, ph = paper_size(paper)
    return MARGIN, 24.0, pw - 2 * MARGIN, 0.47 * ph - 24.0


def book_scale(size_mm, box_mm) -> float:
    """The drawing scale (printed mm per pattern mm, at most 1) of a pattern ``size_mm`` =
    (width, height) in a box (width, height): 1/k for the smallest ``k`` of :data:`BOOK_SCALES`
    times a power of ten at which the pattern and its dimension lines fit."""
    return round_scale(size_mm, (box_mm[0] - DIM_MM, box_mm[1] - DIM_MM), BOOK_SCALES)


def _view(points: np.ndarray, normals: np.ndarray):
    """An orthographic three-quarter view of a surface: (x axis, y axis) of the screen in model space,
    the eye on the side the normals point to, 35 degrees off the mean normal."""
    n = normals.mean(axis=0)
    c = points - points.mean(axis=0)
    if np.linalg.norm(n) < 1e-9:  # a closed or folded surface: its thinnest principal axis
        n = np.linalg.svd(c, full_matrices=False)[2][-1]
    n = n / np.linalg.norm(n)
    flat = c - np.outer(c @ n, n)
    a = np.linalg.svd(flat, full_matrices=False)[2][0]  # the part's long axis across the normal
    b = np.cross(n, a)
    t = math.radians(35.0)
    eye = math.cos(t) * n - math.sin(t) * b  # looking down at the part from in front of it
    x = a - (a @ eye) * eye
    x /= np.linalg.norm(x)
    y = np.cross(eye, x)
    return x, y


def _polyline_path(c, pts, closed=False):
    p = c.beginPath()
    p.moveTo(float(pts[0][0]), float(pts[0][1]))
    for q in pts[1:]:
        p.lineTo(float(q[0]), float(q[1]))
    if closed:
        p.close()
    return p


def _segments_path(c, a, b):
    p = c.beginPath()
    for (x0, y0), (x1, y1) in zip(a.tolist(), b.tolist()):
        p.moveTo(x0, y0)
        p.lineTo(x1, y1)
    return p


class _ToolPicture:
    """The tool seen in one view, mapped into a box of the page (points): the same for every page."""

    def __init__(self, surf, pieces, box_mm):
        dom = np.asarray(surf.domain, dtype=float)
        k = 25
        s = np.linspace(0.0, 1.0, k)
        uu, vv = np.meshgrid(dom[0, 0] + s * (dom[0, 1] - dom[0, 0]), dom[1, 0] + s * (dom[1, 1] - dom[1, 0]),
                             indexing="ij")
        ev = surf.evaluate(np.column_stack([uu.ravel(), vv.ravel()]))
        self.grid = ev.xyz.reshape(k, k, 3)
        self.x, self.y = _view(ev.xyz, ev.normal)
        pts = [ev.xyz] + [_current(p).pattern.outline3d for p in pieces if _current(p) is not None]
        xy = np.concatenate([self.raw(q) for q in pts])
        lo, hi = xy.min(axis=0), xy.max(axis=0)
        bx, by, bw, bh = box_mm
        self.scale = min(bw / max(hi[0] - lo[0], 1e-12), bh / max(hi[1] - lo[1], 1e-12)) * MM
        self.origin = np.array([bx * MM + 0.5 * (bw * MM - self.scale * (hi[0] - lo[0])),
                                by * MM + 0.5 * (bh * MM - self.scale * (hi[1] - lo[1]))]) - self.scale * lo
        self.diag = float(np.linalg.norm(np.ptp(ev.xyz, axis=0)))

    def raw(self, p):
        p = np.asarray(p, dtype=float)
        return np.column_stack([p @ self.x, p @ self.y])

    def page(self, p):
        return self.origin + self.scale * self.raw(p)

    def draw_tool(self, c):
        c.setStrokeColorRGB(0.72, 0.72, 0.72)
        c.setLineWidth(0.3)
        for line in list(self.grid) + list(self.grid.transpose(1, 0, 2)):
            c.drawPath(_polyline_path(c, self.page(line)), stroke=1, fill=0)
        c.setStrokeColorRGB(0.35, 0.35, 0.35)
        c.setLineWidth(0.7)
        edge = np.concatenate([self.grid[:, 0], self.grid[-1, 1:], self.grid[::-1, -1][1:], self.grid[0, ::-1][1:]])
        c.drawPath(_polyline_path(c, self.page(edge), closed=True), stroke=1, fill=0)

    def draw_others(self, c, others):
        c.setStrokeColorRGB(0.62, 0.62, 0.70)
        c.setLineWidth(0.35)
        c.setDash([1.5, 1.5])
        for r in others:
            c.drawPath(_polyline_path(c, self.page(r.pattern.outline3d), closed=True), stroke=1, fill=0)
        c.setDash([])

    def draw_piece(self, c, result):
        c.saveState()
        c.setFillColorRGB(*PIECE_RGB)
        c.setFillAlpha(0.75)
        c.setStrokeColorRGB(0.15, 0.15, 0.15)
        c.setLineWidth(0.9)
        for piece in result.pattern.pieces:
            c.drawPath(_polyline_path(c, self.page(piece.outline3d), closed=True), stroke=1, fill=1)
        c.restoreState()
        mesh, xyz = result.mesh, result.xyz
        for kind, rgb, along in ((WEFT, WEFT_RGB, 0), (WARP, WARP_RGB, 1)):
            ends = mesh.ends[mesh.kind == kind]
            line = mesh.ij[ends[:, 0], along]  # a weft thread is a lattice row, a warp thread a column
            span = int(line.max() - line.min()) + 1 if len(line) else 1
            step = max(1, round(span / THREADS))
            ends = ends[(line - line.min()) % step == 0]
            c.setStrokeColorRGB(*rgb)
            c.setLineWidth(0.45)
            c.drawPath(_segments_path(c, self.page(xyz[ends[:, 0]]), self.page(xyz[ends[:, 1]])), stroke=1, fill=0)

    def draw_rosette(self, c, surface, settings):
        r = rosette(surface, settings.seed, settings.angle_deg)
        arrows = rosette_arrows(r, 0.16 * self.diag)
        for arrow, rgb in zip(arrows, (WEFT_RGB, WARP_RGB)):
            c.setStrokeColorRGB(*rgb)
            c.setLineWidth(1.6)
            c.drawPath(_polyline_path(c, self.page(arrow)), stroke=1, fill=0)
        x, y = self.page(r.origin[None, :])[0]
        c.setFillColorRGB(0, 0, 0)
        c.circle(float(x), float(y), 1.6, stroke=0, fill=1)


# ---------------------------------------------------------------------- pages
def _text(c, x_mm, y_mm, text, size=8.0, font="Helvetica", rgb=(0, 0, 0), align="left"):
    c.setFont(font, size)
    c.setFillColorRGB(*rgb)
    draw = {"left": c.drawString, "right": c.drawRightString, "centre": c.drawCentredString}[align]
    draw(x_mm * MM, y_mm * MM, text)


def _fmt(v, spec, unit=""):
    return "-" if v is None or not math.isfinite(v) else f"{v:{spec}}{unit}"


TABLE_COLUMNS = (  # (heading, width mm, align)
    ("seq.", 9, "right"), ("name", 24, "left"), ("qty", 8, "right"), ("material", 34, "left"),
    ("orient.", 14, "right"), ("flat size mm", 24, "right"), ("area m2", 15, "right"),
    ("shear deg", 14, "right"), ("> lock %", 12, "right"), ("status", 32, "left"),
)


def _cells(row: BookRow) -> list[str]:
    size = "-" if row.size_mm is None else f"{row.size_mm[0]:.0f} x {row.size_mm[1]:.0f}"
    status = row.status + (f", {len(row.warnings)} warn." if row.warnings else "")
    return ["-" if row.sequence is None else str(row.sequence), row.name, str(row.quantity), row.material,
            row.orientation_short, size, _fmt(row.area_m2, ".3f"), _fmt(row.max_shear_deg, ".1f"),
            _fmt(row.beyond_lock_pct, ".1f"), status]


def _clip(c, text, width_mm, size, font="Helvetica"):
    """``text`` cut (with "...") to fit ``width_mm`` at ``size`` points."""
    if c.stringWidth(text, font, size) <= width_mm * MM:
        return text
    while text and c.stringWidth(text + "...", font, size) > width_mm * MM:
        text = text[:-1]
    return text + "..."


def _headings(c, columns, y) -> float:
    """A table's column headings ((title, width mm, align) each) at ``y``; the y of its first row."""
    x = MARGIN
    for title, w, align in columns:
        _text(c, x + (w - 1 if align == "right" else 0), y, title, 7.5, "Helvetica-Bold", align=align)
        x += w
    return y - ROW_MM


def _table(c, rows, y, bottom, header):
    """Draw the stacking table from ``y`` down; a new page (``header()`` drawn on it) when it reaches
    ``bottom``. Returns the y below it."""
    def heading(y):
        _headings(c, TABLE_COLUMNS, y)
        c.setLineWidth(0.5)
        c.setStrokeColorRGB(0, 0, 0)
        c.line(MARGIN * MM, (y - 1.5) * MM, (MARGIN + sum(w for _, w, _ in TABLE_COLUMNS)) * MM, (y - 1.5) * MM)
        return y - ROW_MM
    y = heading(y)
    for row in rows:
        if y < bottom:
            c.showPage()
            y = heading(header())
        x = MARGIN
        bad = row.status.startswith(("failed", "not", "stale", "did not")) or "warning" in row.status
        for (title, w, align), cell in zip(TABLE_COLUMNS, _cells(row)):
            cell = _clip(c, cell, w - 1.5, 7.0)
            _text(c, x + (w - 1 if align == "right" else 0), y, cell, 7.0,
                  rgb=(0.7, 0.2, 0.0) if bad and title == "status" else (0, 0, 0), align=align)
            x += w
        y -= ROW_MM
    return y


SEAM_COLUMNS = (("sew line", 36, "left"), ("seam", 30, "left"), ("panels", 56, "left"), ("lengths mm", 34, "right"),
                ("diff. %", 14, "right"), ("allow. mm", 16, "right"))


def _seam_cells(row, mm: float, allowance: str) -> list[str]:
    lengths = " / ".join("-" if v is None else f"{v * mm:.1f}" for v in row.lengths)
    return [row.name, row.seam, " / ".join(n or "(deleted)" for n in row.panels), lengths,
            "-" if row.difference_pct is None else f"{row.difference_pct:.3f}", allowance]


def _seam_table(c, project, y, bottom, header, seam_allowance_mm):
    """The seams' table (issue 42): each sew line with its panels, their flat lengths, the difference
    and its seam allowance, the rows over the tolerance in the warning colour. Returns the y below it."""
    rows = seam_rows(project)
    if not rows:
        return y
    mm = 1000.0 * project.metres_per_unit
    own = {(s.name, t.name): t.allowance_mm for s in project.sewings for t in s.seams}
    if y < bottom + 3 * ROW_MM:  # the heading and a row or two at least on the page it starts
        c.showPage()
        y = header()
    _text(c, MARGIN, y, "Seams: sew lines matched", 10, "Helvetica-Bold")
    y -= 6

    def heading(y):
        return _headings(c, SEAM_COLUMNS, y)
    y = heading(y)
    for row in rows:
        if y < bottom:
            c.showPage()
            y = heading(header())
        width = own.get((row.sewing, row.seam))
        cells = _seam_cells(row, mm, f"{seam_allowance_mm if width is None else width:g}")
        x = MARGIN
        for (title, w, align), cell in zip(SEAM_COLUMNS, cells):
            _text(c, x + (w - 1 if align == "right" else 0), y, _clip(c, cell, w - 1.5, 7.0), 7.0,
                  rgb=(0.7, 0.2, 0.0) if row.over(mm) and title == "diff. %" else (0, 0, 0), align=align)
            x += w
        y -= ROW_MM
    return y - 4


def _wrap(c, text, width_mm, size):
    words, lines, line = text.split(), [], ""
    for w in words:
        trial = f"{line} {w}".strip()
        if line and c.stringWidth(trial, "Helvetica", size) > width_mm * MM:
            lines.append(line)
            line = w
        else:
            line = trial
    return lines + ([line] if line else [])


def _cover(c, project, rows, checks, pw, ph, title, seam_allowance_mm=0.0):
    today = _dt.date.today().isoformat()

    def header():
        _text(c, MARGIN, ph - MARGIN - 6, f"{title}: stacking table (continued)", 12, "Helvetica-Bold")
        return ph - MARGIN - 16
    _text(c, MARGIN, ph - MARGIN - 8, title, 18, "Helvetica-Bold")
    n_solved = sum(r.size_mm is not None for r in rows)
    lines = [f"project {project.name}" + (f", source {Path(project.source).name}" if project.source else ""),
             f"model units {project.units}; flat sizes in mm; {len(rows)} pieces, {n_solved} drawn; "
             f"{sum(r.quantity for r in rows)} to cut",
             f"flatweave {__version__}, {today}"]
    for i, line in enumerate(lines):
        _text(c, MARGIN, ph - MARGIN - 16 - 5 * i, line, 9)
    y = _table(c, rows, ph - MARGIN - 38, MARGIN + 12, header)
    y -= 4
    y = _seam_table(c, project, y, MARGIN + 12, header, seam_allowance_mm)
    _text(c, MARGIN, y, "Project checks" if checks else "Project checks: none", 10, "Helvetica-Bold")
    y -= 5.5
    for w in checks:
        for line in _wrap(c, w, pw - 2 * MARGIN, 8):
            if y < MARGIN + 8:
                c.showPage()
                y = header()
            _text(c, MARGIN, y, line, 8, rgb=(0.6, 0.25, 0.0))
            y -= 4.0


def _dimension(c, a, b, offset, text, vertical):
    """A dimension line from ``a`` to ``b`` (points), moved ``offset`` points across, with ticks and text."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = np.array([-offset, 0.0]) if vertical else np.array([0.0, -offset])
    c.setStrokeColorRGB(0.25, 0.25, 0.25)
    c.setLineWidth(0.35)
    c.line(*(a + 0.2 * d), *(a + 1.15 * d))  # extension lines
    c.line(*(b + 0.2 * d), *(b + 1.15 * d))
    p, q = a + d, b + d
    c.line(*p, *q)
    t = np.array([1.2, 1.2]) * MM
    c.line(*(p - t), *(p + t))  # architectural ticks
    c.line(*(q - t), *(q + t))
    mid = 0.5 * (p + q)
    c.setFont("Helvetica", 7)
    c.setFillColorRGB(0.1, 0.1, 0.1)
    if vertical:
        c.saveState()
        c.translate(mid[0] - 1.5 * MM, mid[1])
        c.rotate(90)
        c.drawCentredString(0, 0, text)
        c.restoreState()
    else:
        c.drawCentredString(mid[0], mid[1] - 3.2 * MM, text)


def _mm_text(v):
    return f"{v:.1f} mm" if v < 100 else f"{v:.0f} mm"


def _pattern(c, sheet, paper):
    """The flat pattern at a stated scale in :func:`pattern_box`; returns the scale."""
    bx, by, bw, bh = pattern_box(paper)
    lo = np.min([p.bounds()[0] for p in sheet.pieces], axis=0)
    hi = np.max([p.bounds()[1] for p in sheet.pieces], axis=0)
    size = hi - lo
    scale = book_scale(size, (bw, bh))
    ox = bx + DIM_MM + 0.5 * (bw - DIM_MM - scale * size[0]) - scale * lo[0]
    oy = by + DIM_MM + 0.5 * (bh - DIM_MM - scale * size[1]) - scale * lo[1]
    c.saveState()
    c.translate(ox * MM, oy * MM)
    c.scale(scale * MM, scale * MM)
    draw_sheet(c, sheet, unit_width=scale, labels=False)
    c.restoreState()
    p0 = np.array([ox + scale * lo[0], oy + scale * lo[1]]) * MM
    p1 = np.array([ox + scale * hi[0], oy + scale * hi[1]]) * MM
    gap = 0.55 * DIM_MM * MM
    _dimension(c, p0, [p1[0], p0[1]], gap, _mm_text(size[0]), vertical=False)
    _dimension(c, p0, [p0[0], p1[1]], gap, _mm_text(size[1]), vertical=True)
    # scale bar: a round length about a quarter of the box, and the scale in words
    draw_scale_bar(c, bx, by - 8.0, nice_length(0.25 * bw / scale), scale, "(printed at 100 %)")
    return scale


def _piece_page(c, project, piece, row, sheet, picture, others, paper, number, total, title):
    pw, ph = paper_size(paper)
    top = ph - MARGIN
    seq = "" if piece.sequence is None else f"sequence {piece.sequence}  "
    _text(c, MARGIN, top - 6, f"{piece.name}", 16, "Helvetica-Bold")
    _text(c, pw - MARGIN, top - 6, f"{seq}({number} of {total})", 10, align="right")
    m = piece.settings.material
    _text(c, MARGIN, top - 12, f"{row.material} ({fabric_kind(m)} {m.ratio}); orientation {row.orientation}; "
                               f"quantity {piece.quantity}", 9)
    pic = (MARGIN, 0.50 * ph, 0.56 * (pw - 2 * MARGIN), top - 18 - 0.50 * ph)
    picture.draw_tool(c)
    picture.draw_others(c, others)
    r = _current(piece)
    if r is not None:
        picture.draw_piece(c, r)
    picture.draw_rosette(c, piece.surface, piece.settings)
    _text(c, pic[0], pic[1] - 4, "the tool: this piece filled, its weft (red) and warp (blue) threads, the arrows "
                                 "at its seed; the other pieces dashed", 6.5, rgb=(0.3, 0.3, 0.3))
    # the numbers, right of the picture
    s = piece.settings
    m = r.metrics if r is not None else {}
    x, y = pic[0] + pic[2] + 6, top - 22
    facts = [("status", row.status),
             ("flat size", "-" if row.size_mm is None else f"{row.size_mm[0]:.1f} x {row.size_mm[1]:.1f} mm"),
             ("flat area", _fmt(row.area_m2, ".4f", " m2")),
             ("spacing", f"{s.spacing:g} {project.units}"),
             ("nodes", str(m.get("nodes", "-"))),
             ("boundary error", _fmt(m.get("boundary_error_pct"), ".3f", " %")),
             ("area error", _fmt(m.get("area_error_pct"), ".3f", " %")),
             ("max shear", _fmt(m.get("max_shear_deg"), ".1f", " deg")
              + f" (warn {s.material.warn_deg:g}, lock {s.material.lock_deg:g})"),
             ("beyond lock", _fmt(m.get("area_beyond_lock_pct"), ".2f", " % of the area")),
             ("thread strain", _fmt(m.get("max_thread_strain_pct"), ".2f", " % max"))]
    for label, value in facts:
        _text(c, x, y, label, 8, "Helvetica-Bold")
        _text(c, x + 24, y, _clip(c, value, pw - MARGIN - x - 24, 8), 8)
        y -= 4.6
    y -= 2
    width = pw - MARGIN - x
    for w in row.warnings[:6]:
        for line in _wrap(c, f"- {w}", width, 7)[:3]:
            _text(c, x, y, line, 7, rgb=(0.6, 0.25, 0.0))
            y -= 3.4
    scale = None
    if sheet is not None:
        scale = _pattern(c, sheet, paper)
    else:
        bx, by, bw, bh = pattern_box(paper)
        _text(c, bx + bw / 2, by + bh / 2, f"no pattern: {row.status}", 12, align="centre", rgb=(0.6, 0.25, 0.0))
    _text(c, MARGIN, MARGIN - 6, f"{title}; page of {piece.name}"
          + (f"; pattern {scale_text(scale)}" if scale else "") + f"; flatweave {__version__}", 6.5,
          rgb=(0.3, 0.3, 0.3))
    return scale


MARKER_COLUMNS = (("piece", 62, "left"), ("copies", 14, "right"), ("source", 110, "left"))


def _marker_page(c, material, marker, sources, paper, number, total, title):
    """A marker's page (or pages, when its table of pieces is long): its numbers, the whole marker at a round
    scale, the pieces on it."""
    pw, ph = paper_size(paper)
    top = ph - MARGIN
    L, W = marker.length, marker.roll_width

    def header():
        _text(c, MARGIN, top - 6, f"Marker: {material} (continued)", 12, "Helvetica-Bold")
        return top - 16
    _text(c, MARGIN, top - 6, f"Marker: {material}", 16, "Helvetica-Bold")
    _text(c, pw - MARGIN, top - 6, f"(marker {number} of {total})", 10, align="right")
    facts = [("material", material), ("roll width", f"{W:g} mm"), ("length", f"{L:.1f} mm"),
             ("utilisation", f"{100 * marker.utilisation:.2f} %"), ("waste", f"{marker.waste / 1e6:.4f} m2"),
             ("pieces placed", f"{len(marker.placements)}"), ("gap", f"{marker.gap:g} mm")]
    y = top - 14
    for label, value in facts:
        _text(c, MARGIN, y, label, 8, "Helvetica-Bold")
        _text(c, MARGIN + 26, y, _clip(c, value, pw - 2 * MARGIN - 26, 8), 8)
        y -= 4.6
    if marker.stopped:
        _text(c, MARGIN, y, "stopped before its time: the best marker found so far", 8, rgb=(0.6, 0.25, 0.0))
        y -= 4.6
    # the marker across the page, at the round scale that fits a box under the numbers
    y -= 4
    box = (pw - 2 * MARGIN, 0.40 * ph)
    scale = marker_scale(marker, box)
    drawn = scale * W
    draw_marker(c, marker, placed_sheet(marker, sources, scale), scale,
                (MARGIN + 0.5 * (box[0] - scale * L), y - drawn))
    y -= drawn + 8
    draw_scale_bar(c, MARGIN, y, nice_length(0.25 * L), scale, "(printed at 100 %)")
    y -= 10

    def heading(y):
        return _headings(c, MARKER_COLUMNS, y)
    _text(c, MARGIN, y, "Pieces on the marker", 10, "Helvetica-Bold")
    y = heading(y - 6)
    copies = [sum(1 for p in marker.placements if p.item == k) for k in range(len(marker.items))]
    for item, n, src in zip(marker.items, copies, sources):
        if y < MARGIN + 4:
            c.showPage()
            y = heading(header())
        x = MARGIN
        for (_, w, align), cell in zip(MARKER_COLUMNS, (item.name, str(n), f"{src.source}, piece {src.index + 1}")):
            _text(c, x + (w - 1 if align == "right" else 0), y, _clip(c, cell, w - 1.5, 7.0), 7.0, align=align)
            x += w
        y -= ROW_MM
    _text(c, MARGIN, MARGIN - 6, f"{title}; marker of {material}; drawn at {scale_text(scale)}; flatweave "
                                 f"{__version__}", 6.5, rgb=(0.3, 0.3, 0.3))


def plybook_bytes(project, paper: str = "a4", seam_allowance_mm: float = 0.0, title: str | None = None,
                  markers=()) -> bytes:
    """The project's ply book as PDF bytes (see the module's docstring). ``seam_allowance_mm``:
    the patterns' cut lines (0: the sew line is the cut line, as composites plies are cut).
    ``markers``: (material name, :class:`flatweave.studies.nesting.Marker`, its
    :class:`flatweave.export.marker.MarkerSource` per item) each, a page each after the pieces'."""
    from reportlab.pdfgen import canvas  # reportlab loads when a book is written

    pw, ph = paper_size(paper)
    if not math.isfinite(seam_allowance_mm) or not 0 <= seam_allowance_mm <= 1000:
        raise SettingsError(f"seam allowance {seam_allowance_mm!r} mm must be from 0 to 1000")
    mm_per_unit(project.units)
    title = title or f"{project.name}: ply book"
    order = book_order(project)
    sheets = {p.name: _sheet(project, p, seam_allowance_mm) for p in order}
    rows = [_row(p, sheets[p.name]) for p in order]
    buf = io.BytesIO()
    c = canvas.Canvas(buf, pagesize=(pw * MM, ph * MM), pageCompression=1)
    c.setTitle(title)
    c.setCreator(f"flatweave {__version__}")
    _cover(c, project, rows, project_checks(project), pw, ph, title, seam_allowance_mm)
    c.showPage()
    top = ph - MARGIN
    box = (MARGIN, 0.50 * ph, 0.56 * (pw - 2 * MARGIN), top - 18 - 0.50 * ph)
    # one picture per surface the pieces lie on (a job's faces, its files), the same on each of its pages
    pictures = {}
    for p in order:
        if id(p.surface) not in pictures:
            pictures[id(p.surface)] = _ToolPicture(p.surface, [q for q in order if q.surface is p.surface], box)
    solved = {p.name: _current(p) for p in order}
    for k, (piece, row) in enumerate(zip(order, rows)):
        others = [r for name, r in solved.items() if r is not None and name != piece.name
                  and r.surface is piece.surface]
        _piece_page(c, project, piece, row, sheets[piece.name], pictures[id(piece.surface)], others, paper, k + 1,
                    len(order), title)
        c.showPage()
    markers = list(markers)
    for k, (material, marker, sources) in enumerate(markers):
        _marker_page(c, material, marker, sources, paper, k + 1, len(markers), title)
        c.showPage()
    c.save()
    return buf.getvalue()


def write_ply_book(project, path, paper: str = "a4", seam_allowance_mm: float = 0.0) -> Path:
    """Write the project's ply book to ``path`` (a .pdf; atomically: a failure leaves what was there)."""
    path = Path(path)
    if path.suffix.lower() != ".pdf":
        raise SettingsError(f"a ply book is a PDF: {path.name} does not end in .pdf")
    atomic_write_bytes(path, plybook_bytes(project, paper, seam_allowance_mm))
    return path
