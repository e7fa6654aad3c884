"""SVG at true size: width and height in millimetres and a viewBox in mm, so
1 user unit is 1 mm when printed or imported. The AAMA layers are groups
(``id="layer-1-cut"`` ...), with Inkscape's layer attributes so editors show
them as layers. The sheet's y axis points up, SVG's down: y is flipped.

Where each piece sits is recorded in ``<metadata>``: a ``flatweave:sheet``
element (namespace :data:`NS`) with ``mm-per-unit`` and, per piece, a
``flatweave:piece`` with its ``offset-mm`` (sheet = result xy x mm per unit +
offset) and ``transform``, the SVG matrix taking the result file's
``nodes.xy`` (model units) to this file's user units (mm), so a pattern
overlaid with the JSON, OBJ or VTP lines up.
"""

from __future__ import annotations

from xml.sax.saxutils import escape, quoteattr

import numpy as np

from flatweave.export.sheet import Sheet

__all__ = ["MARGIN_MM", "NS", "svg_text", "SVG_LAYERS"]

NS = "https://flatweave.invalid/ns/svg-sheet/1"  # a name, not a page

MARGIN_MM = 10.0

# group id -> (AAMA layer, stroke colour, stroke width mm)
SVG_LAYERS = {
    "layer-1-cut": ("1", "#000000", 0.35),
    "layer-14-sew": ("14", "#1a7f37", 0.25),
    "layer-8-internal": ("8", "#1f4fd1", 0.25),
    "layer-4-notch": ("4", "#c62828", 0.35),
    "layer-7-grain": ("7", "#8e24aa", 0.3),
    "layer-11-cutout": ("11", "#00838f", 0.3),
    "layer-13-drill": ("13", "#b8860b", 0.3),
    "layer-15-annotation": ("15", "#555555", 0.2),
}


def svg_text(sheet: Sheet, margin: float = MARGIN_MM) -> str:
    """The sheet as an SVG document (text)."""
    w, h = sheet.size
    W, H = w + 2 * margin, h + 2 * margin

    def pts(a: np.ndarray) -> str:
        a = np.asarray(a, dtype=float)
        return " ".join(f"{x + margin:.4f},{H - (y + margin):.4f}" for x, y in a)

    def path(a, closed):
        tag = "polygon" if closed else "polyline"
        return f'<{tag} points="{pts(a)}"/>'

    groups = {gid: [] for gid in SVG_LAYERS}
    for p in sheet.pieces:
        groups["layer-1-cut"].append(path(p.outer, True))
        groups["layer-14-sew"].append(path(p.sew, True))
        groups["layer-14-sew"] += [path(hh, True) for hh in p.holes]
        groups["layer-11-cutout"] += [path(hh, True) for hh in (p.hole_cuts if p.cut is not None else p.holes)]
        groups["layer-8-internal"] += [path(leg, False) for leg in p.internal]
        groups["layer-4-notch"] += [path(n, False) for n in p.notches]
        for d in p.drills:
            groups["layer-13-drill"].append(
                f'<circle cx="{d[0] + margin:.4f}" cy="{H - (d[1] + margin):.4f}" r="1"/>')
        groups["layer-7-grain"].append(path(p.grain, False))
        groups["layer-7-grain"] += [path(hd, False) for hd in p.grain_heads]
        x, y = p.label_at
        for i, line in enumerate(p.label):
            yy = y - 1.6 * p.label_height * i
            groups["layer-15-annotation"].append(
                f'<text x="{x + margin:.4f}" y="{H - (yy + margin):.4f}" font-size="{p.label_height:.3f}" '
                f'font-family="sans-serif" stroke="none" fill="#555555">{escape(line)}</text>')
    out = ['<?xml version="1.0" encoding="UTF-8"?>',
           f'<svg xmlns="http://www.w3.org/2000/svg" '
           f'xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape" '
           f'width="{W:.4f}mm" height="{H:.4f}mm" viewBox="0 0 {W:.4f} {H:.4f}">',
           f'<title>{escape(", ".join(p.name for p in sheet.pieces))} (flatweave, mm)</title>',
           f'<metadata><flatweave:sheet xmlns:flatweave={quoteattr(NS)} units="mm" '
           f'model-units={quoteattr(sheet.units)} mm-per-unit="{sheet.mm_per_unit:.12g}">']
    s = sheet.mm_per_unit
    for p in sheet.pieces:
        ox, oy = (float(v) for v in p.offset)
        # X = s x + ox + margin, Y = H - margin - (s y + oy)
        matrix = f"matrix({s:.12g} 0 0 {-s:.12g} {ox + margin:.6f} {H - margin - oy:.6f})"
        out.append(f'<flatweave:piece name={quoteattr(p.name)} offset-mm="{ox:.6f} {oy:.6f}" '
                   f'transform="{matrix}"/>')
    out.append("</flatweave:sheet></metadata>")
    for gid, items in groups.items():
        layer, colour, width = SVG_LAYERS[gid]
        out.append(f'<g id={quoteattr(gid)} inkscape:groupmode="layer" inkscape:label={quoteattr(layer)} '
                   f'fill="none" stroke="{colour}" stroke-width="{width}" stroke-linejoin="round">')
        out += items
        out.append("</g>")
    out.append("</svg>")
    return "\n".join(out) + "\n"
