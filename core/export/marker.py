"""A marker's files (issue 43): the pieces placed on the roll, as a DXF, an SVG, a PDF and a CSV of placements.

Each file holds a :class:`flatweave.studies.nesting.Marker` and, per item of it, the
:class:`flatweave.export.sheet.SheetPiece` it was cut from (its lines: cut line, sew
line, notches, grain line, label), in millimetres, x along the roll and y across it
(0 to the roll's width):

* DXF: :func:`flatweave.export.dxf.dxf_bytes` with a block per piece (in its own
  frame) inserted once per copy placed, turned by the placement's rotation about
  the block's origin, at its translation (a mirror pair's mirrored copies insert a
  block of their own, "NAME mirrored", drawn reflected with its text upright: no
  negative scales, which not every cutter reads); the roll's edges and ends on layer 15.
* SVG: the roll and every placed copy's cut line (and sew line, notches and grain
  line), at 1:1 in millimetres, y up as on the roll, the marker's length,
  width and utilisation in its title.
* PDF (:func:`marker_pdf`): the whole marker on one page at a round scale (1:25, say: the
  smallest reduction of :data:`flatweave.export.pdf.ROUND_SCALES` that fits, the page
  turned to landscape when that draws it larger), the roll and every placed copy's
  lines, each copy named inside where its name fits, its numbers in the title; then
  (``tiled``) an assembly map of the 1:1 tiles and the tiles themselves, printed at
  1:1 on portrait pages as a pattern's cut files are
  (:func:`flatweave.export.pdf.draw_tiles`: overlap, trim lines, registration marks,
  test squares, the tiles named), the roll's edges and ends drawn grey.
* CSV: a row per placed copy: ``source`` (the input it came from), ``piece`` (its
  index in that input's ``pattern.pieces``), ``name``, ``copy``, ``x``, ``y``,
  ``rotation_deg``, ``mirrored``: the piece's cut outline, in the coordinates of
  its ``pattern.pieces[k].outline`` in millimetres, reflected first when
  ``mirrored`` is true (x negated), rotated about the origin and then moved by (x, y).
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass, replace
from xml.sax.saxutils import escape

import numpy as np

from flatweave.export.dxf import dxf_bytes
from flatweave.export.pdf import (MM, NAME_FONT, OVERLAP_MM, PAGE_MARGIN_MM, SHEET_MARGIN_MM, draw_scale_bar,
                                  draw_sheet, draw_tile_grid, draw_tiles, name_place, nice_length, paper_size,
                                  round_scale, scale_text, tile_grid, tiles)
from flatweave.export.sheet import Sheet, SheetPiece
from flatweave.studies.nesting import Marker, Placement

__all__ = ["MarkerSource", "marker_csv", "marker_dxf", "marker_svg", "marker_pdf", "MARKER_FORMATS", "marker_files",
           "placed_sheet", "marker_scale", "draw_marker", "marker_summary"]

MARKER_FORMATS = (".dxf", ".svg", ".pdf", ".csv")
ROLL_RGB = (0.45, 0.45, 0.45)  # the roll's edges and ends


@dataclass(frozen=True)
class MarkerSource:
    """Where an item of a marker came from: the input's name (a file's), the index of the pattern
    piece in it, and the sheet piece drawn for it (sheet coordinates: its ``offset`` is taken off)."""

    source: str
    index: int
    sheet_piece: SheetPiece


def _framed(sp: SheetPiece) -> SheetPiece:
    """``sp`` in its own frame (the pattern outline's, mm): its offset taken off every line."""
    return sp.moved(-np.asarray(sp.offset, dtype=float))


def marker_csv(marker: Marker, sources) -> bytes:
    """The placements as CSV (see the module docstring); ``sources`` per item (:class:`MarkerSource`)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["source", "piece", "name", "copy", "x", "y", "rotation_deg", "mirrored"])
    for p in marker.placements:
        src = sources[p.item]
        w.writerow([src.source, src.index, marker.items[p.item].name, p.copy + 1, f"{p.x:.4f}", f"{p.y:.4f}",
                    f"{p.rotation_deg:.6g}", "true" if p.mirrored else "false"])
    return buf.getvalue().encode("utf-8")


def marker_dxf(marker: Marker, sources, name: str, variant: str = "astm") -> bytes:
    """The marker as a DXF: a block per item, inserted per copy (see the module docstring)."""
    pieces = [_framed(s.sheet_piece) for s in sources]
    inserts = {k: [(p.x, p.y, p.rotation_deg) for p in marker.placements if p.item == k and not p.mirrored]
               for k in range(len(pieces))}
    for k in range(len(sources)):  # a mirror pair's other half: a block of its own, drawn mirrored, text upright
        turns = [(p.x, p.y, p.rotation_deg) for p in marker.placements if p.item == k and p.mirrored]
        if turns:
            flip = Placement(k, 0, 0.0, 0.0, 0.0, mirrored=True)
            inserts[len(pieces)] = turns
            pieces.append(replace(_placed(pieces[k], flip), name=f"{pieces[k].name} mirrored"))
    sheet = Sheet(tuple(pieces), 0.0, "mm", name)
    return dxf_bytes(sheet, variant, inserts=inserts, roll=(marker.length, marker.roll_width))


def _path(points: np.ndarray, closed: bool) -> str:
    d = " ".join(f"{'M' if i == 0 else 'L'}{x:.3f},{y:.3f}" for i, (x, y) in enumerate(points))
    return d + (" Z" if closed else "")


def marker_svg(marker: Marker, sources, name: str) -> bytes:
    """The marker as an SVG at 1:1 in millimetres (see the module docstring)."""
    L, W = marker.length, marker.roll_width
    margin = 10.0
    title = (f"{name}: marker {L:.1f} mm long on a roll {W:g} mm wide, utilisation {100 * marker.utilisation:.2f} %, "
             f"{len(marker.placements)} pieces")
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{L + 2 * margin:.3f}mm" height="{W + 2 * margin:.3f}mm" '
           f'viewBox="{-margin:.3f} {-margin:.3f} {L + 2 * margin:.3f} {W + 2 * margin:.3f}">',
           f"<title>{escape(title)}</title>",
           # y up, as on the roll: the drawing flipped about the roll's middle
           f'<g transform="translate(0 {W:.3f}) scale(1 -1)">',
           f'<rect x="0" y="0" width="{L:.3f}" height="{W:.3f}" fill="none" stroke="#888" stroke-width="0.5"/>']
    for p in marker.placements:
        sp = _framed(sources[p.item].sheet_piece)
        it = marker.items[p.item]
        out.append(f'<g><title>{escape(it.name)} copy {p.copy + 1}</title>')
        out.append(f'<path d="{_path(p.place(sp.outer), True)}" fill="#dde6f0" stroke="#000" stroke-width="0.4"/>')
        if sp.cut is not None:
            out.append(f'<path d="{_path(p.place(sp.sew), True)}" fill="none" stroke="#3a3" stroke-width="0.3" '
                       f'stroke-dasharray="2 1"/>')
        for n in sp.notches:
            out.append(f'<path d="{_path(p.place(n), False)}" stroke="#c00" stroke-width="0.5"/>')
        out.append(f'<path d="{_path(p.place(sp.grain), False)}" stroke="#a0a" stroke-width="0.3"/>')
        out.append("</g>")
    out += ["</g>", "</svg>"]
    return "\n".join(out).encode("utf-8")


def marker_summary(marker: Marker) -> str:
    """The marker's numbers in a line, as its PDF's title states them."""
    return (f"marker {marker.length:.1f} mm long on a roll {marker.roll_width:g} mm wide, utilisation "
            f"{100 * marker.utilisation:.2f} %, waste {marker.waste / 1e6:.4g} m^2, {len(marker.placements)} pieces "
            f"placed")


def _placed(sp: SheetPiece, p) -> SheetPiece:
    """A sheet piece in its own frame (:func:`_framed`) placed on the roll by placement ``p``, every line with it;
    its offset is where its frame's origin lands."""
    def pl(a):
        return None if a is None else p.place(np.asarray(a, dtype=float).reshape(-1, 2))

    return replace(sp, sew=pl(sp.sew), cut=pl(sp.cut), holes=tuple(pl(h) for h in sp.holes),
                   hole_cuts=tuple(pl(h) for h in sp.hole_cuts), internal=tuple(pl(q) for q in sp.internal),
                   notches=tuple(pl(q) for q in sp.notches), drills=pl(sp.drills), grain=pl(sp.grain),
                   grain_heads=tuple(pl(q) for q in sp.grain_heads), label_at=pl(sp.label_at)[0],
                   offset=pl(sp.offset)[0])


def placed_sheet(marker: Marker, sources, scale: float | None = 1.0) -> Sheet:
    """Every placed copy's sheet piece on the roll, in the placements' order, as one :class:`Sheet` in mm (x
    along the roll, y across it; the roll from (0, 0)): each turned and moved as its placement places the
    item's outline, named by its item. Its label is the name alone, placed where
    :func:`flatweave.export.pdf.name_place` puts it for a drawing at ``scale`` (printed mm per mm), upright,
    when it fits inside the piece there, else none (a piece's own label is placed for the piece upright
    and alone); ``scale`` None: no labels. Draw it with ``draw_sheet(..., labels=True)``."""
    from reportlab.pdfbase.pdfmetrics import getAscentDescent, stringWidth
    from shapely.geometry import Polygon, box

    within = (-SHEET_MARGIN_MM, -SHEET_MARGIN_MM, marker.length + SHEET_MARGIN_MM,
              marker.roll_width + SHEET_MARGIN_MM)
    ascent, descent = getAscentDescent(NAME_FONT, 1.0)  # per unit of font size; descent < 0
    out = []
    for p in marker.placements:
        name = marker.items[p.item].name
        sp = replace(_placed(_framed(sources[p.item].sheet_piece), p), name=name, system_text=(), annotation=())
        if scale is not None:
            x, y, size = name_place(sp, scale, within)
            # name_place's last resort centres a name too big for its piece: such a name is left off
            where = box(x, y + descent * size, x + stringWidth(name, NAME_FONT, size), y + ascent * size)
            if Polygon(sp.outer).buffer(0).contains(where):
                sp = replace(sp, annotation=(name,), label_at=np.array([x, y]), label_height=size)
        out.append(sp)
    return Sheet(tuple(out), 0.0, "mm", "marker")


def marker_scale(marker: Marker, box_mm) -> float:
    """The round scale (printed mm per mm, at most 1) at which the whole roll used, length x width, fits a
    box (width, height) mm (:func:`flatweave.export.pdf.round_scale`)."""
    return round_scale((marker.length, marker.roll_width), box_mm)


def _roll_edges(marker: Marker) -> list[np.ndarray]:
    L, W = marker.length, marker.roll_width
    return [np.array([[0.0, 0.0], [L, 0.0]]), np.array([[0.0, W], [L, W]]), np.array([[0.0, 0.0], [0.0, W]]),
            np.array([[L, 0.0], [L, W]])]


def draw_marker(c, marker: Marker, sheet: Sheet, scale: float, origin_mm) -> None:
    """Draw a marker on canvas ``c`` at ``scale`` (printed mm per mm), the roll's corner (0, 0) at
    ``origin_mm`` (page mm from the bottom-left): the roll used (a grey rectangle, length x width), then
    ``sheet``'s pieces (:func:`placed_sheet`), filled, with their lines and labels. The canvas's state is kept."""
    c.saveState()
    c.translate(origin_mm[0] * MM, origin_mm[1] * MM)
    c.scale(scale * MM, scale * MM)  # 1 unit = 1 mm on the roll
    c.setStrokeColorRGB(*ROLL_RGB)
    c.setLineWidth(0.3 / scale)
    c.rect(0.0, 0.0, marker.length, marker.roll_width, stroke=1, fill=0)
    draw_sheet(c, sheet, unit_width=scale, labels=True, fill=True)
    c.restoreState()


def marker_pdf(marker: Marker, sources, name: str, paper: str = "a4", tiled: bool = True) -> bytes:
    """The marker as a PDF (see the module docstring): the whole marker on a page at a round scale, then,
    when ``tiled``, the assembly map and the 1:1 tiles on ``paper`` (a4 or letter)."""
    from reportlab.pdfgen import canvas

    pw, ph = paper_size(paper)
    L, W = marker.length, marker.roll_width
    top, bottom = 24.0, 26.0  # the title and its numbers above the drawing; the scale bar and a note below

    def fit(page):  # the round scale of the whole marker on a page (width, height)
        return marker_scale(marker, (page[0] - 2 * PAGE_MARGIN_MM, page[1] - top - bottom))

    # the page turned as draws the marker larger; a tie goes to landscape for a marker longer than wide
    turns = [(ph, pw), (pw, ph)] if L >= W else [(pw, ph), (ph, pw)]
    page = max(turns, key=fit)
    aw, ah = page[0] - 2 * PAGE_MARGIN_MM, page[1] - top - bottom
    buf = io.BytesIO()
    c = canvas.Canvas(buf, pagesize=(page[0] * MM, page[1] * MM), pageCompression=1)
    c.setTitle(f"{name}: marker")
    c.setCreator("flatweave")

    def heading(text, note):
        c.setFont("Helvetica-Bold", 12)
        c.setFillColorRGB(0, 0, 0)
        c.drawString(PAGE_MARGIN_MM * MM, (page[1] - 14) * MM, text)
        c.setFont("Helvetica", 9)
        c.drawString(PAGE_MARGIN_MM * MM, (page[1] - 20) * MM, note)

    def footer(text):
        c.setFont("Helvetica", 7)
        c.setFillColorRGB(0.3, 0.3, 0.3)
        c.drawString(PAGE_MARGIN_MM * MM, (PAGE_MARGIN_MM - 7) * MM, text)

    scale = fit(page)
    origin = (PAGE_MARGIN_MM + 0.5 * (aw - scale * L), bottom + 0.5 * (ah - scale * W))
    heading(f"{name}: {marker_summary(marker)}", f"{scale_text(scale)}; x along the roll, y across it; "
                                                 f"gap {marker.gap:g} mm between pieces"
            + ("; stopped: the best marker found so far" if marker.stopped else ""))
    draw_marker(c, marker, placed_sheet(marker, sources, scale), scale, origin)
    draw_scale_bar(c, PAGE_MARGIN_MM, bottom - 12.0, nice_length(0.25 * L), scale, "(printed at 100 %)")
    rows, cols, cw, ch = tile_grid((L, W), paper)
    grid = tiles(placed_sheet(marker, sources, None), paper, (L, W)) if tiled else []
    printed = [show for _, _, show in grid]
    footer("the whole marker" + (f"; then its assembly map and {sum(printed)} tiles at 1:1 on {paper} paper: "
                                 f"print them at 100 % (no fit-to-page)" if tiled else ""))
    c.showPage()
    if not tiled:
        c.save()
        return buf.getvalue()

    # the assembly map: the tiles' grid (from the drawing's top-left, its margins included) over the marker
    gw, gh = cols * (cw - OVERLAP_MM) + OVERLAP_MM, rows * (ch - OVERLAP_MM) + OVERLAP_MM
    H = W + 2 * SHEET_MARGIN_MM  # the drawing's height: the grid hangs from its top
    map_scale = round_scale((gw, gh), (aw, ah))
    gx, gy = PAGE_MARGIN_MM + 0.5 * (aw - map_scale * gw), bottom + 0.5 * (ah - map_scale * gh)
    below = gh - H  # how far the grid's bottom row reaches under the drawing
    corner = (gx, gy + map_scale * below)  # the page point of the drawing's bottom-left corner
    heading(f"{name}: assembly map, {sum(printed)} pages of a {rows} x {cols} grid",
            f"{scale_text(map_scale)}; the 1:1 tiles follow, named as here")
    draw_marker(c, marker, placed_sheet(marker, sources, None), map_scale,
                (corner[0] + map_scale * SHEET_MARGIN_MM, corner[1] + map_scale * SHEET_MARGIN_MM))
    draw_tile_grid(c, (rows, cols, cw, ch, printed), corner, map_scale, H)
    draw_scale_bar(c, PAGE_MARGIN_MM, bottom - 12.0, nice_length(0.25 * L), map_scale)
    footer(f"tiles overlap by {OVERLAP_MM:g} mm; cut each page on its dashed trim lines and lay it over its "
           f"neighbours, matching the registration marks; pale tiles are blank and not printed")
    c.showPage()

    draw_tiles(c, placed_sheet(marker, sources, 1.0), paper, f"{name}: marker", size=(L, W),
               edges=_roll_edges(marker))
    c.save()
    return buf.getvalue()


def marker_files(marker: Marker, sources, path, name: str, variant: str = "astm", paper: str = "a4") -> list[tuple]:
    """(path, bytes) of the marker in the format ``path``'s suffix names (a key of MARKER_FORMATS); ``paper``
    the PDF's."""
    suffix = str(path).lower().rsplit(".", 1)[-1]
    if suffix == "dxf":
        return [(path, marker_dxf(marker, sources, name, variant))]
    if suffix == "svg":
        return [(path, marker_svg(marker, sources, name))]
    if suffix == "pdf":
        return [(path, marker_pdf(marker, sources, name, paper))]
    if suffix == "csv":
        return [(path, marker_csv(marker, sources))]
    raise ValueError(f"a marker is written as {', '.join(MARKER_FORMATS)}, not {path}")
