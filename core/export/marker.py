"""A marker's files (issue 43): the pieces placed on the roll, as a DXF, an SVG and a CSV of placements.

Each file holds a :class:`flatweave.studies.nesting.Marker` and, per item of it, the
:class:`flatweave.export.sheet.SheetPiece` it was cut from (its lines: cut line, sew
line, notches, grain line, label), in millimetres, x along the roll and y across it
(0 to the roll's width):

* DXF: :func:`flatweave.export.dxf.dxf_bytes` with a block per piece (in its own
  frame) inserted once per copy placed, turned by the placement's rotation about
  the block's origin, at its translation; the roll's edges and ends on layer 15.
* SVG: the roll and every placed copy's cut line (and sew line, notches and grain
  line), at 1:1 in millimetres, y up as on the roll, the marker's length,
  width and utilisation in its title.
* CSV: a row per placed copy: ``source`` (the input it came from), ``piece`` (its
  index in that input's ``pattern.pieces``), ``name``, ``copy``, ``x``, ``y``,
  ``rotation_deg``, ``mirrored``: the piece's cut outline, in the coordinates of
  its ``pattern.pieces[k].outline`` in millimetres, rotated about the origin and
  then moved by (x, y).
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from xml.sax.saxutils import escape

import numpy as np

from flatweave.export.dxf import dxf_bytes
from flatweave.export.sheet import Sheet, SheetPiece
from flatweave.studies.nesting import Marker

__all__ = ["MarkerSource", "marker_csv", "marker_dxf", "marker_svg", "MARKER_FORMATS", "marker_files"]

MARKER_FORMATS = (".dxf", ".svg", ".csv")


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
    pieces = tuple(_framed(s.sheet_piece) for s in sources)
    sheet = Sheet(pieces, 0.0, "mm", name)
    inserts = {k: [(p.x, p.y, p.rotation_deg) for p in marker.placements if p.item == k] for k in range(len(pieces))}
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


def marker_files(marker: Marker, sources, path, name: str, variant: str = "astm") -> list[tuple]:
    """(path, bytes) of the marker in the format ``path``'s suffix names (a key of MARKER_FORMATS)."""
    suffix = str(path).lower().rsplit(".", 1)[-1]
    if suffix == "dxf":
        return [(path, marker_dxf(marker, sources, name, variant))]
    if suffix == "svg":
        return [(path, marker_svg(marker, sources, name))]
    if suffix == "csv":
        return [(path, marker_csv(marker, sources))]
    raise ValueError(f"a marker is written as {', '.join(MARKER_FORMATS)}, not {path}")
