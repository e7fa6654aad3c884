"""PDF for printing at 1:1 on A4 or US Letter, written with reportlab.

Pages, in order:

1. overview: every piece scaled to fit one page, with a scale bar and the scale
   (once, beside the bar), each piece's name inside it, and the labels in full;
2. assembly map: the same drawing with the grid of tiles, each named by
   row letter and column number (A1 is the top-left tile);
3. the tiles, row by row, at 1:1. Neighbouring tiles overlap by
   ``OVERLAP_MM``; a dashed trim line marks where to cut a page so it lies on
   its neighbour, and registration marks (circle and cross) at the trim
   corners line the pages up.

Every page carries a test square, drawn in the page's own units, so a printer
that scaled the page is caught before anything is cut: 100 mm in a corner of
the overview and the assembly map; on a tile, where no line of the pattern,
label or page mark is (the 100 mm square where it fits, else a 50 mm or 20 mm
one, as near the trim box's bottom-left corner as it can). A tile's
neighbour labels name the neighbouring tiles that are printed, and say
"blank" for those that are not.
"""

from __future__ import annotations

import io
import math
from dataclasses import replace

import numpy as np

from flatweave.errors import SettingsError
from flatweave.export.sheet import Sheet
from flatweave.export.sheet import label_box

__all__ = ["PAPERS", "MM", "TEST_SQUARE_MM", "TILE_SQUARES_MM", "OVERLAP_MM", "PAGE_MARGIN_MM", "FRONT_PAGES",
           "tile_grid", "tiles", "page_count", "name_place", "scale_text", "sheet_marks", "pdf_bytes",
           "draw_sheet", "nice_length", "draw_test_square", "paper_size", "draw_scale_bar", "ROUND_SCALES",
           "round_scale", "draw_tiles", "draw_tile_grid", "SHEET_MARGIN_MM", "NAME_FONT", "NAME_MM"]

MM = 72.0 / 25.4  # PDF points per millimetre
PAPERS = {"a4": (210.0, 297.0), "letter": (215.9, 279.4)}
PAGE_MARGIN_MM = 12.0  # unprinted edge plus room for the page label
OVERLAP_MM = 10.0
TEST_SQUARE_MM = 100.0
TILE_SQUARES_MM = (100.0, 50.0, 20.0)  # the test square of a tile: the largest that finds free space
SQUARE_CLEARANCE_MM = 3.0
SHEET_MARGIN_MM = 10.0  # blank border round the pieces
FRONT_PAGES = 2  # the overview and the assembly map, before the tiles
NAME_FONT = "Helvetica-Bold"  # the pieces' names on the scaled pages
NAME_MM = (3.0, 2.5, 2.0, 1.5)  # their printed heights, the largest that fits inside the piece
ROUND_SCALES = (1.0, 2.0, 2.5, 5.0, 10.0, 20.0, 25.0, 50.0)  # 1:k, then the same times powers of ten

# stroke colours (r, g, b) and widths (mm) of the drawn lines
STYLE = {
    "cut": ((0.0, 0.0, 0.0), 0.35),
    "sew": ((0.10, 0.50, 0.22), 0.25),
    "internal": ((0.12, 0.31, 0.82), 0.25),
    "notch": ((0.78, 0.16, 0.16), 0.35),
    "grain": ((0.56, 0.14, 0.67), 0.30),
    "cutout": ((0.0, 0.51, 0.56), 0.30),
}


def paper_size(paper: str) -> tuple[float, float]:
    """(width, height) of a portrait sheet of paper, mm."""
    try:
        return PAPERS[paper.lower()]
    except KeyError:
        raise SettingsError(f"unknown paper {paper!r}: use one of {', '.join(PAPERS)}") from None


def tile_grid(sheet_size_mm: tuple[float, float], paper: str = "a4") -> tuple[int, int, float, float]:
    """(rows, cols, tile width, tile height) of the 1:1 tiles for a sheet of this size (mm),
    margins included (the drawing is the sheet plus ``SHEET_MARGIN_MM`` all round)."""
    pw, ph = paper_size(paper)
    cw, ch = pw - 2 * PAGE_MARGIN_MM, ph - 2 * PAGE_MARGIN_MM
    W = sheet_size_mm[0] + 2 * SHEET_MARGIN_MM
    H = sheet_size_mm[1] + 2 * SHEET_MARGIN_MM
    cols = max(1, math.ceil((W - OVERLAP_MM) / (cw - OVERLAP_MM)))
    rows = max(1, math.ceil((H - OVERLAP_MM) / (ch - OVERLAP_MM)))
    return rows, cols, cw, ch


def tiles(sheet: Sheet, paper: str = "a4", size=None) -> list[tuple[int, int, bool]]:
    """Every tile of the 1:1 grid as (row, column, printed); a tile is printed
    when some piece lies in it (blank tiles are left out of the PDF). ``size``:
    the drawing's (width, height) mm from (0, 0) when it is not the sheet's own
    (a marker's roll, which its pieces need not reach)."""
    import shapely
    from shapely.geometry import Polygon
    from shapely.ops import unary_union

    size = sheet.size if size is None else size
    rows, cols, cw, ch = tile_grid(size, paper)
    H = size[1] + 2 * SHEET_MARGIN_MM
    region = unary_union([Polygon(p.outer).buffer(0) for p in sheet.pieces])
    shapely.prepare(region)
    r, col = (a.ravel() for a in np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij"))
    x0 = col * (cw - OVERLAP_MM) - SHEET_MARGIN_MM  # each tile's window in sheet coordinates
    y1 = H - r * (ch - OVERLAP_MM) - SHEET_MARGIN_MM
    printed = shapely.intersects(region, shapely.box(x0, y1 - ch, x0 + cw, y1))
    return [(int(a), int(b), bool(c)) for a, b, c in zip(r, col, printed)]


def page_count(sheet: Sheet, paper: str = "a4") -> int:
    """Pages :func:`pdf_bytes` writes for this sheet: the overview and the assembly map,
    then one per printed tile of :func:`tiles` (cheap: nothing is drawn)."""
    return FRONT_PAGES + sum(show for _, _, show in tiles(sheet, paper))


def _tile_name(r: int, c: int) -> str:
    letters = ""
    r += 1
    while r:
        r, rem = divmod(r - 1, 26)
        letters = chr(65 + rem) + letters
    return f"{letters}{c + 1}"


def _polyline(c, pts, closed):
    p = c.beginPath()
    p.moveTo(float(pts[0][0]), float(pts[0][1]))
    for x, y in pts[1:]:
        p.lineTo(float(x), float(y))
    if closed:
        p.close()
    c.drawPath(p, stroke=1, fill=0)


def _region(c, p):
    """Fill a piece (outline less its internal cut-outs)."""
    path = c.beginPath()
    for ring in (p.outer,) + tuple(p.hole_cuts if p.cut is not None else p.holes):
        path.moveTo(float(ring[0][0]), float(ring[0][1]))
        for x, y in ring[1:]:
            path.lineTo(float(x), float(y))
        path.close()
    c.drawPath(path, stroke=0, fill=1)


def draw_sheet(c, sheet: Sheet, unit_width: float, labels: bool = True, fill: bool = False):
    """Draw the pieces in the current user space (1 unit = 1 sheet mm); line
    widths are given in mm and divided by ``unit_width`` (mm per unit drawn).
    ``labels``: the full labels (1:1); else each piece's name (:func:`name_place`)."""

    def style(name):
        rgb, w = STYLE[name]
        c.setStrokeColorRGB(*rgb)
        c.setLineWidth(w / unit_width)

    W, H = sheet.size
    drawing = (-SHEET_MARGIN_MM, -SHEET_MARGIN_MM, W + SHEET_MARGIN_MM, H + SHEET_MARGIN_MM)
    c.setLineJoin(1)
    if fill:
        c.setFillColorRGB(0.95, 0.95, 0.93)
        for p in sheet.pieces:
            _region(c, p)
    for p in sheet.pieces:
        style("cut")
        _polyline(c, p.outer, True)
        if p.cut is not None:
            style("sew")
            c.setDash([2.0 / unit_width, 1.0 / unit_width])
            _polyline(c, p.sew, True)
            c.setDash([])
        style("sew")
        for h in p.holes:
            _polyline(c, h, True)
        style("cutout")
        for h in (p.hole_cuts if p.cut is not None else ()):
            _polyline(c, h, True)
        style("internal")
        for leg in p.internal:
            _polyline(c, leg, False)
        style("notch")
        for n in p.notches:
            _polyline(c, n, False)
        style("grain")
        _polyline(c, p.grain, False)
        for hd in p.grain_heads:
            _polyline(c, hd, False)
        for d in p.drills:
            c.circle(float(d[0]), float(d[1]), 1.0, stroke=1, fill=0)
        if labels:  # full labels at their size on the sheet (1:1 tiles)
            c.setFillColorRGB(0.3, 0.3, 0.3)
            c.setFont("Helvetica", p.label_height)
            x, y = p.label_at
            for i, line in enumerate(p.label):
                c.drawString(float(x), float(y - 1.6 * p.label_height * i), line)
        else:  # scaled pages: the name only, placed for the printed size (the label's place is for 1:1)
            x, y, size = name_place(p, unit_width, drawing)
            c.setFillColorRGB(0.3, 0.3, 0.3)
            c.setFont(NAME_FONT, size)
            c.drawString(x, y, p.name)


def name_place(piece, scale: float, within) -> tuple[float, float, float]:
    """Where a page drawn at ``scale`` (printed mm per sheet mm) writes a piece's name:
    (x, y, size), the baseline's start and the font size, in sheet mm.

    The name's box (``NAME_FONT``'s ascent and descent, the name's advance width) lies
    inside the piece (inside its outer line, off its cut-outs), clear of its drawn lines
    where it can be, at the largest printed height of ``NAME_MM`` that fits. A piece too
    small for the smallest gets the name centred on its point farthest from the outline,
    moved as little as needed to lie in ``within`` = (xmin, ymin, xmax, ymax), the drawn
    area, so no part of it falls off the page.
    """
    import shapely
    from reportlab.pdfbase.pdfmetrics import getAscentDescent, stringWidth
    from shapely.geometry import LineString, Point, Polygon
    from shapely.ops import polylabel, unary_union

    cutouts = piece.hole_cuts if piece.cut is not None else piece.holes
    region = Polygon(piece.outer, [h for h in cutouts if len(h) >= 3]).buffer(0)
    if region.geom_type != "Polygon":
        region = max(region.geoms, key=lambda g: g.area)
    lines = [piece.sew, *piece.holes, *piece.internal, *piece.notches, piece.grain, *piece.grain_heads]
    drawn = unary_union([LineString(q) for q in lines if len(q) >= 2] + [Point(d).buffer(1.0) for d in piece.drills])
    b = np.asarray(region.bounds, dtype=float)
    ascent, descent = getAscentDescent(NAME_FONT, 1.0)  # per unit of font size; descent < 0

    def box_size(size):
        return stringWidth(piece.name, NAME_FONT, size), (ascent - descent) * size

    shapely.prepare(region)
    for avoid_lines in (True, False):  # clear of every line at any size before crossing one
        for printed in NAME_MM:
            size = printed / scale
            w, h = box_size(size)
            gap = 0.3 * size
            free = region.buffer(-gap, join_style="mitre")
            if avoid_lines and not drawn.is_empty:
                free = free.difference(drawn.buffer(gap))
            if free.is_empty or w >= b[2] - b[0] or h >= b[3] - b[1]:
                continue
            X, Y = (g.ravel() for g in np.meshgrid(np.linspace(b[0], b[2] - w, 40), np.linspace(b[1], b[3] - h, 40)))
            boxes = shapely.box(X, Y, X + w, Y + h)
            ok = shapely.contains(free, boxes)
            if ok.any():
                k = int(np.argmax(shapely.distance(boxes[ok], free.boundary)))  # the most room round it
                return float(X[ok][k]), float(Y[ok][k] - descent * size), float(size)
    size = NAME_MM[-1] / scale
    w, h = box_size(size)
    extent = float(max(b[2] - b[0], b[3] - b[1]))
    cx, cy = polylabel(region, tolerance=max(extent / 200.0, 1e-9)).coords[0]
    x0, y0 = cx - w / 2, cy - h / 2
    x0 = min(max(x0, within[0]), within[2] - w)
    y0 = min(max(y0, within[1]), within[3] - h)
    return float(x0), float(y0 - descent * size), float(size)


def draw_test_square(c, x_mm: float, y_mm: float, side_mm: float = TEST_SQUARE_MM):
    """A test square of ``side_mm``, in page units (points), bottom-left at (x, y) mm."""
    c.saveState()
    c.setStrokeColorRGB(0.25, 0.25, 0.25)
    c.setLineWidth(0.5)
    s = side_mm * MM
    c.rect(x_mm * MM, y_mm * MM, s, s, stroke=1, fill=0)
    c.setFillColorRGB(0.25, 0.25, 0.25)
    if side_mm >= 50:
        c.setFont("Helvetica", 8)
        c.drawCentredString(x_mm * MM + s / 2, y_mm * MM + s / 2 + 4, f"{side_mm:g} mm test square")
        c.drawCentredString(x_mm * MM + s / 2, y_mm * MM + s / 2 - 8, "measure before cutting")
    else:
        c.setFont("Helvetica", 6)
        c.drawCentredString(x_mm * MM + s / 2, y_mm * MM + s / 2 + 1, f"{side_mm:g} mm")
        c.drawCentredString(x_mm * MM + s / 2, y_mm * MM + s / 2 - 6, "test")
    c.restoreState()


def sheet_marks(sheet: Sheet):
    """Everything drawn of the sheet (lines, drill holes, label boxes), in sheet mm, as one
    shapely geometry: where a tile's test square must not go."""
    from shapely.geometry import LineString, Point, box
    from shapely.ops import unary_union

    parts = []
    for p in sheet.pieces:
        rings = [p.outer, p.sew, *p.holes, *p.hole_cuts]
        parts += [LineString(np.vstack([r, r[:1]])) for r in rings if len(r) >= 2]
        parts += [LineString(q) for q in (*p.internal, *p.notches, p.grain, *p.grain_heads) if len(q) >= 2]
        parts += [Point(d).buffer(1.0) for d in p.drills]
        (x0, y0), (x1, y1) = label_box(p.label_at, p.label, p.label_height)
        parts.append(box(x0, y0, x1, y1))
        parts.append(Point(p.label_at).buffer(3.0))  # the scaled pages' name
    return unary_union(parts).buffer(0.5)


def _tile_square(marks, r: int, col: int, rows: int, cols: int, cw: float, ch: float, x0: float, y1: float):
    """(x, y, side) in page mm of a tile's test square: the largest of ``TILE_SQUARES_MM``
    that lies in the trim box clear of the pattern's marks and the page's own, nearest
    the trim box's bottom-left corner; the smallest in that corner if none is clear."""
    import shapely
    from shapely.affinity import translate
    from shapely.geometry import Point, box
    from shapely.ops import unary_union

    # sheet mm -> page mm on this tile (as pdf_bytes draws it)
    dx = PAGE_MARGIN_MM + SHEET_MARGIN_MM - x0
    dy = PAGE_MARGIN_MM + SHEET_MARGIN_MM - (y1 - ch)
    content = box(PAGE_MARGIN_MM, PAGE_MARGIN_MM, PAGE_MARGIN_MM + cw, PAGE_MARGIN_MM + ch)
    left = PAGE_MARGIN_MM + (OVERLAP_MM if col > 0 else 0.0)
    top = PAGE_MARGIN_MM + ch - (OVERLAP_MM if r > 0 else 0.0)
    right, bottom = PAGE_MARGIN_MM + cw, PAGE_MARGIN_MM
    page = [Point(x, y).buffer(6.0) for x in (left, right) for y in (bottom, top)]  # registration marks
    mid_x, mid_y = PAGE_MARGIN_MM + cw / 2, PAGE_MARGIN_MM + ch / 2
    page += [box(PAGE_MARGIN_MM, mid_y - 3, PAGE_MARGIN_MM + 22, mid_y + 5),  # neighbours' names
             box(right - 22, mid_y - 3, right, mid_y + 5),
             box(mid_x - 15, PAGE_MARGIN_MM + ch - 6, mid_x + 15, PAGE_MARGIN_MM + ch),
             box(mid_x - 15, PAGE_MARGIN_MM, mid_x + 15, PAGE_MARGIN_MM + 6)]
    blocked = unary_union([translate(marks, dx, dy).intersection(content)] + page)
    shapely.prepare(blocked)
    g = SQUARE_CLEARANCE_MM
    for side in TILE_SQUARES_MM:
        xs = np.arange(left + g, right - g - side + 1e-9, 2.0)
        ys = np.arange(bottom + g, top - g - side + 1e-9, 2.0)
        if len(xs) == 0 or len(ys) == 0:
            continue
        X, Y = (a.ravel() for a in np.meshgrid(xs, ys))
        order = np.argsort((X - left) ** 2 + (Y - bottom) ** 2, kind="stable")
        X, Y = X[order], Y[order]
        free = ~shapely.intersects(blocked, shapely.box(X - g, Y - g, X + side + g, Y + side + g))
        if free.any():
            k = int(np.argmax(free))
            return float(X[k]), float(Y[k]), side
    side = TILE_SQUARES_MM[-1]
    return left + g, bottom + g, side


def _registration(c, x: float, y: float, r: float = 3.0):
    """A registration mark at (x, y) mm in page space."""
    c.saveState()
    c.setStrokeColorRGB(0, 0, 0)
    c.setLineWidth(0.4)
    c.circle(x * MM, y * MM, r * MM, stroke=1, fill=0)
    c.line((x - 1.6 * r) * MM, y * MM, (x + 1.6 * r) * MM, y * MM)
    c.line(x * MM, (y - 1.6 * r) * MM, x * MM, (y + 1.6 * r) * MM)
    c.restoreState()


def nice_length(limit: float) -> float:
    """The largest 1, 2, 5 x 10^k not above ``limit``."""
    k = 10 ** math.floor(math.log10(limit))
    for m in (5, 2, 1):
        if m * k <= limit:
            return m * k
    return k


def draw_scale_bar(c, x0: float, y0: float, length: float, scale: float, note: str = "") -> None:
    """A scale bar on canvas ``c`` from (``x0``, ``y0``) mm on the page: ``length``
    drawing mm (printed ``length * scale`` mm) ticked in fifths, then its length and
    :func:`scale_text` (and ``note``) in words; the canvas's state is kept."""
    c.saveState()
    c.setStrokeColorRGB(0, 0, 0)
    c.setFillColorRGB(0, 0, 0)
    c.setLineWidth(0.8)
    c.line(x0 * MM, y0 * MM, (x0 + length * scale) * MM, y0 * MM)
    for t in np.linspace(0.0, length, 6):
        h = 2.5 if t in (0.0, length) else 1.5
        c.line((x0 + t * scale) * MM, y0 * MM, (x0 + t * scale) * MM, (y0 + h) * MM)
    c.setFont("Helvetica", 8)
    c.drawString((x0 + length * scale + 3) * MM, (y0 - 1) * MM,
                 f"{length:g} mm    {scale_text(scale)}{' ' + note if note else ''}")
    c.restoreState()


def round_scale(size_mm, box_mm, steps=ROUND_SCALES) -> float:
    """The drawing scale (printed mm per drawing mm, at most 1: never enlarged) at which a drawing
    ``size_mm`` = (width, height) fits a box (width, height) mm: 1/k for the smallest ``k`` of
    ``steps`` times a power of ten that is at least the reduction that just fits."""
    w, h = max(size_mm[0], 1e-9), max(size_mm[1], 1e-9)
    need = max(w / box_mm[0], h / box_mm[1])  # the reduction that just fits
    decade = 10.0 ** math.floor(math.log10(need)) if need > 1 else 1.0
    for _ in range(40):
        for k in steps:
            if k * decade >= need:
                return 1.0 / (k * decade)
        decade *= 10.0
    return 1.0 / need


def scale_text(scale: float) -> str:
    """The drawing's scale (printed mm per sheet mm) as a drawing states it, to 3 significant
    figures: "scale 1:10.4" for a reduction, "scale 2.25:1" for an enlargement."""
    if scale >= 1.0:
        return f"scale {scale:.3g}:1"
    return f"scale 1:{1 / scale:.3g}"


def _scaled_page(c, sheet: Sheet, pw: float, ph: float, title: str, grid=None):
    """Draw the whole sheet scaled to fit, and with ``grid`` the whole tile grid (its
    tiles reach past a sheet smaller than one); returns (scale, origin) used."""
    W, H = (s + 2 * SHEET_MARGIN_MM for s in sheet.size)
    fit_w, fit_h, below = W, H, 0.0  # what must fit, in drawing mm: the drawing, the grid's tiles
    if grid is not None:
        rows, cols, cw, ch, _ = grid
        fit_w = max(W, cols * (cw - OVERLAP_MM) + OVERLAP_MM)
        below = max(0.0, rows * (ch - OVERLAP_MM) + OVERLAP_MM - H)  # the bottom row's reach under y = 0
        fit_h = H + below
    top, bottom = 22.0, PAGE_MARGIN_MM + TEST_SQUARE_MM + 6.0  # title above; scale bar, test square below
    aw, ah = pw - 2 * PAGE_MARGIN_MM, ph - top - bottom
    scale = min(aw / fit_w, ah / fit_h)
    ox = PAGE_MARGIN_MM + 0.5 * (aw - scale * fit_w)
    oy = bottom + 0.5 * (ah - scale * fit_h) + scale * below
    c.setFont("Helvetica-Bold", 12)
    c.setFillColorRGB(0, 0, 0)
    c.drawString(PAGE_MARGIN_MM * MM, (ph - 14) * MM, title)
    c.saveState()
    c.translate(ox * MM, oy * MM)
    c.scale(scale * MM, scale * MM)
    c.translate(SHEET_MARGIN_MM, SHEET_MARGIN_MM)
    draw_sheet(c, sheet, unit_width=scale, labels=False)
    c.restoreState()
    if grid is None:  # the pieces' labels in full, below the scale bar
        c.setFillColorRGB(0.2, 0.2, 0.2)
        y = bottom - 22.0
        for p in sheet.pieces[:4]:
            for line in p.label:
                if y < PAGE_MARGIN_MM:
                    break
                c.setFont("Helvetica", 7)
                c.drawString(PAGE_MARGIN_MM * MM, y * MM, line)
                y -= 3.6
            y -= 2.0
    if grid is not None:  # the tiles, named as on their pages; blank ones are not printed
        draw_tile_grid(c, grid, (ox, oy), scale, H)
    # scale bar: a round length about a quarter of the drawing's width
    draw_scale_bar(c, PAGE_MARGIN_MM, bottom - 12.0, nice_length(0.25 * W), scale)
    return scale, (ox, oy)


def draw_tile_grid(c, grid, origin_mm, scale: float, height_mm: float) -> None:
    """The 1:1 tiles' grid over a drawing at ``scale``, each tile named as on its page (A1 top left), the
    blank ones (not printed) pale. ``grid`` = (rows, cols, tile width, tile height, printed per tile in
    :func:`tiles`' order), ``origin_mm`` the page point (mm) of the drawing's bottom-left corner (the
    sheet's (-SHEET_MARGIN_MM, -SHEET_MARGIN_MM)), ``height_mm`` the drawing's height (the sheet's plus
    its margins), where the top row starts. The canvas's state is kept."""
    rows, cols, cw, ch, printed = grid
    ox, oy = origin_mm
    c.saveState()
    c.setLineWidth(0.6)
    for r in range(rows):
        for col in range(cols):
            x0 = col * (cw - OVERLAP_MM)
            y1 = height_mm - r * (ch - OVERLAP_MM)
            shade = 0.0 if printed[r * cols + col] else 0.75
            c.setStrokeColorRGB(0.85, 0.2 + shade * 0.6, 0.2 + shade * 0.6)
            c.setFillColorRGB(0.85, 0.2 + shade * 0.6, 0.2 + shade * 0.6)
            c.rect((ox + scale * x0) * MM, (oy + scale * (y1 - ch)) * MM, scale * cw * MM,
                   scale * ch * MM, stroke=1, fill=0)
            c.setFont("Helvetica-Bold", max(6, min(16, 0.25 * scale * cw * MM)))
            c.drawCentredString((ox + scale * (x0 + cw / 2)) * MM, (oy + scale * (y1 - ch / 2)) * MM,
                                _tile_name(r, col))
    c.restoreState()


def draw_tiles(c, sheet: Sheet, paper: str = "a4", title: str = "flatweave pattern", size=None, edges=(),
               labels: bool = True) -> int:
    """The sheet's printed tiles at 1:1 on canvas ``c``, a page each (each ended by ``showPage``; the page
    size set to the paper's, portrait): the tile's window of the drawing clipped to the printable area,
    the trim lines where a neighbour overlaps, registration marks, the neighbours' names, a test square
    clear of the drawing, the tile's name and a footer naming ``title``. ``size``: the drawing's (width,
    height) mm from (0, 0) (default the sheet's; :func:`tiles`); ``edges``: polylines ((k, 2) sheet mm)
    drawn grey under the pieces on every tile and kept clear by the test square (a marker's roll);
    ``labels``: the pieces' full labels, else their names (:func:`draw_sheet`). Returns the pages drawn."""
    from shapely.geometry import LineString
    from shapely.ops import unary_union

    pw, ph = paper_size(paper)
    size = sheet.size if size is None else size
    rows, cols, cw, ch = tile_grid(size, paper)
    H = size[1] + 2 * SHEET_MARGIN_MM
    grid = tiles(sheet, paper, size)
    n_printed = sum(show for _, _, show in grid)
    edges = [np.asarray(e, dtype=float) for e in edges]
    marks = sheet_marks(sheet)
    if edges:
        marks = unary_union([marks] + [LineString(e).buffer(0.5) for e in edges if len(e) >= 2])
    shown = {(r, col) for r, col, show in grid if show}
    # each piece's reach: its outer line's box and its label's (a label that found no room inside may stick
    # out), grown by the widest line drawn; its other marks lie inside it
    boxes = [np.vstack([p.bounds(), label_box(p.label_at, p.label, p.label_height)]) for p in sheet.pieces]
    reach = np.array([np.r_[b.min(axis=0), b.max(axis=0)] for b in boxes]) + np.array([-1.0, -1.0, 1.0, 1.0])
    page = 0
    for r, col, show in grid:
        if not show:
            continue
        page += 1
        c.setPageSize((pw * MM, ph * MM))
        x0 = col * (cw - OVERLAP_MM)  # the tile's window on the drawing, mm
        y1 = H - r * (ch - OVERLAP_MM)
        wx, wy = x0 - SHEET_MARGIN_MM, y1 - ch - SHEET_MARGIN_MM  # its bottom-left corner on the sheet
        # only the pieces that reach into the window are drawn on it (a long marker has hundreds)
        here = (reach[:, 0] <= wx + cw) & (reach[:, 2] >= wx) & (reach[:, 1] <= wy + ch) & (reach[:, 3] >= wy)
        c.saveState()
        clip = c.beginPath()
        clip.rect(PAGE_MARGIN_MM * MM, PAGE_MARGIN_MM * MM, cw * MM, ch * MM)
        c.clipPath(clip, stroke=0, fill=0)
        c.translate(PAGE_MARGIN_MM * MM, PAGE_MARGIN_MM * MM)
        c.scale(MM, MM)  # from here on 1 unit = 1 mm: true size
        c.translate(SHEET_MARGIN_MM - x0, SHEET_MARGIN_MM - (y1 - ch))
        if edges:
            c.setStrokeColorRGB(0.45, 0.45, 0.45)
            c.setLineWidth(0.5)
            for e in edges:
                _polyline(c, e, False)
        if here.any():
            draw_sheet(c, replace(sheet, pieces=tuple(p for p, h in zip(sheet.pieces, here) if h)), unit_width=1.0,
                       labels=labels, fill=True)
        c.restoreState()
        _tile_marks(c, r, col, rows, cols, cw, ch, shown)
        draw_test_square(c, *_tile_square(marks, r, col, rows, cols, cw, ch, x0, y1))
        name = _tile_name(r, col)
        c.setFont("Helvetica-Bold", 11)
        c.setFillColorRGB(0, 0, 0)
        c.drawString(PAGE_MARGIN_MM * MM, (ph - PAGE_MARGIN_MM + 3) * MM,
                     f"{name}   row {_tile_name(r, 0)[:-1]}, column {col + 1}   "
                     f"(tile {page} of {n_printed})")
        _footer(c, pw, f"{title}; 1:1; overlap {OVERLAP_MM:g} mm")
        c.showPage()
    return page


def pdf_bytes(sheet: Sheet, paper: str = "a4", title: str = "flatweave pattern") -> bytes:
    """The sheet as a tiled 1:1 PDF (overview, assembly map, tiles)."""
    from reportlab.pdfgen import canvas

    pw, ph = paper_size(paper)
    rows, cols, cw, ch = tile_grid(sheet.size, paper)
    W, H = (s + 2 * SHEET_MARGIN_MM for s in sheet.size)
    buf = io.BytesIO()
    c = canvas.Canvas(buf, pagesize=(pw * MM, ph * MM), pageCompression=1)
    c.setTitle(title)
    c.setCreator("flatweave")

    scale, _ = _scaled_page(c, sheet, pw, ph, f"{title}: overview")  # its scale is stated by the bar
    _footer(c, pw, f"overview, {len(sheet.pieces)} piece(s), {W:.0f} x {H:.0f} mm; "
                   f"print the tiles at 100 % (no fit-to-page)")
    _test_square_corner(c, pw, ph)
    c.showPage()

    grid = tiles(sheet, paper)
    printed = [t[2] for t in grid]
    n_printed = sum(printed)
    _scaled_page(c, sheet, pw, ph, f"{title}: assembly map, {n_printed} pages of a {rows} x {cols} grid",
                 grid=(rows, cols, cw, ch, printed))
    _footer(c, pw, f"tiles overlap by {OVERLAP_MM:g} mm; cut each page on its dashed trim lines "
                   f"and lay it over its neighbours, matching the registration marks; pale tiles are blank "
                   f"and not printed")
    _test_square_corner(c, pw, ph)
    c.showPage()

    draw_tiles(c, sheet, paper, title)
    c.save()
    return buf.getvalue()


def _test_square_corner(c, pw, ph):
    draw_test_square(c, pw - PAGE_MARGIN_MM - TEST_SQUARE_MM, PAGE_MARGIN_MM + 2.0)


def _footer(c, pw, text):
    c.setFont("Helvetica", 7)
    c.setFillColorRGB(0.3, 0.3, 0.3)
    c.drawString(PAGE_MARGIN_MM * MM, (PAGE_MARGIN_MM - 7) * MM, text)


def _tile_marks(c, r, col, rows, cols, cw, ch, shown=None):
    """Content border, trim lines where a neighbour overlaps, registration marks."""
    x0, y0 = PAGE_MARGIN_MM, PAGE_MARGIN_MM
    c.saveState()
    c.setStrokeColorRGB(0.6, 0.6, 0.6)
    c.setLineWidth(0.3)
    c.rect(x0 * MM, y0 * MM, cw * MM, ch * MM, stroke=1, fill=0)
    # the trim box: cut off the overlap on the sides that lie under a neighbour
    left = x0 + (OVERLAP_MM if col > 0 else 0.0)
    top = y0 + ch - (OVERLAP_MM if r > 0 else 0.0)
    right, bottom = x0 + cw, y0
    c.setStrokeColorRGB(0, 0, 0)
    c.setDash([3, 2])
    if col > 0:
        c.line(left * MM, y0 * MM, left * MM, (y0 + ch) * MM)
    if r > 0:
        c.line(x0 * MM, top * MM, (x0 + cw) * MM, top * MM)
    c.setDash([])
    c.restoreState()
    for x, y in ((left, top), (right, top), (left, bottom), (right, bottom)):
        _registration(c, x, y)
    # the neighbours' names at the edges: printed tiles by name, the others "blank"

    def nb(rr, cc):
        return _tile_name(rr, cc) if shown is None or (rr, cc) in shown else "blank"

    c.setFont("Helvetica", 7)
    c.setFillColorRGB(0.3, 0.3, 0.3)
    if col > 0:
        c.drawString((x0 + 1) * MM, (y0 + ch / 2) * MM, f"< {nb(r, col - 1)}")
    if col < cols - 1:
        c.drawRightString((x0 + cw - 1) * MM, (y0 + ch / 2) * MM, f"{nb(r, col + 1)} >")
    if r > 0:
        c.drawCentredString((x0 + cw / 2) * MM, (y0 + ch - 4) * MM, f"^ {nb(r - 1, col)}")
    if r < rows - 1:
        c.drawCentredString((x0 + cw / 2) * MM, (y0 + 2) * MM, f"v {nb(r + 1, col)}")
