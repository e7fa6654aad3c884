"""Make docs/images/panels_patterns.png: the bundled garment front split into four panels by a centre
seam and a waist seam (both matched), their cut patterns with the seams' notches.

    .venv/bin/python docs/panels_figure.py [OUT_DIR]

The panels are solved as the window's Solve all does (``flatweave.document.matching.solve_all``),
their sheets built as the cut files are (``flatweave.document.sewing.piece_sheet``: notches at the
seams' ends, every 50 mm and at the one placed on the waist seam; 10 mm allowance, 15 mm along the
waist seam) and drawn with Pillow: sew line grey, cut line black, notches red, grain line green.
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from flatweave.document import sewing as S
from flatweave.document.checks import seam_rows
from flatweave.document.matching import solve_all
from flatweave.document.project import new_project
from flatweave.export.sheet import join_sheets
from flatweave.reading.examples import load_example

REPO = Path(__file__).resolve().parent.parent


def bodice():
    g = load_example("garment")
    p = new_project(g, "bodice", "garment", spacing=0.015, units="m")
    p = S.add_seam(p, S.SeamLine("centre", np.array([[0.5, -0.05], [0.5, 1.05]]), matched=True))
    return S.add_seam(p, S.SeamLine("waist", np.array([[-0.05, 0.45], [1.05, 0.55]]), matched=True,
                                    allowance_mm=15.0, notches=((0.3, 0.48),)))


def draw(sheet, path: Path, width: int = 1400) -> None:
    lo = np.min([p.bounds()[0] for p in sheet.pieces], axis=0) - 20.0
    hi = np.max([p.bounds()[1] for p in sheet.pieces], axis=0) + 20.0
    k = width / (hi[0] - lo[0])
    height = int((hi[1] - lo[1]) * k)
    im = Image.new("RGB", (width, height), "white")
    d = ImageDraw.Draw(im)

    def px(pts):
        pts = np.asarray(pts, dtype=float)
        return [(float((x - lo[0]) * k), float(height - (y - lo[1]) * k)) for x, y in pts]

    for p in sheet.pieces:
        d.line(px(np.vstack([p.sew, p.sew[:1]])), fill=(150, 150, 150), width=2)
        if p.cut is not None:
            d.line(px(np.vstack([p.cut, p.cut[:1]])), fill=(0, 0, 0), width=3)
        for n in p.notches:
            d.line(px(n), fill=(220, 0, 0), width=4)
        d.line(px(p.grain), fill=(0, 140, 0), width=2)
        for head in p.grain_heads:
            d.line(px(head), fill=(0, 140, 0), width=2)
        c = px(p.sew.mean(axis=0)[None])[0]
        d.text((c[0] - 30, c[1] + 40), p.name, fill=(0, 0, 0))
    im.save(path)


def main(out_dir: Path) -> None:
    project, _, report = solve_all(bodice(), workers=2)
    print(report.message)
    for r in seam_rows(project):
        print(f"{r.name}: {r.panels[0]} / {r.panels[1]} {r.lengths[0] * 1000:.1f} / {r.lengths[1] * 1000:.1f} mm, "
              f"{r.difference_pct:.3f} %")
    sheet = join_sheets([S.piece_sheet(project, p.name, 10.0, 50.0) for p in project.pieces], "bodice")
    # laid out as they sew together: by where each panel lies on the surface (u across, v up)
    where = {p.name: p.result.uv.mean(axis=0) for p in project.pieces}
    placed = []
    for sp in sheet.pieces:
        u, v = where[sp.name.replace("bodice ", "")] if sp.name not in where else where[sp.name]
        lo, hi = sp.bounds()
        col, row = int(u > 0.5), int(v > 0.5)
        placed.append(sp.moved([col * 330.0 - lo[0] + (0.0 if col else 300.0 - (hi[0] - lo[0])),
                                row * 380.0 - lo[1] + (0.0 if row else 330.0 - (hi[1] - lo[1]))]))
    out = out_dir / "panels_patterns.png"
    draw(replace(sheet, pieces=tuple(placed)), out, width=900)
    print(out)


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "docs" / "images")
