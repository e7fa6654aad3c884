"""The hole in the drape: a doubly curved panel with an arm hole (the garment panel of
tests/test_meshsurf.py), as a NURBS with a (u, v) hole and as a 64 x 64 mesh, flattened at three
spacings: errors, largest shear, and the node pairs that lie on each other (closer than half a
spacing on the surface, more than two lattice steps apart). Run from the repository root:

    .venv/bin/python benchmarks/hole_drape.py

Results: benchmarks/results/hole_drape.md.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from core.meshsurf import _clamped_knots, clean_mesh, fit_bspline, mesh_surface
from core.nurbs import NurbsSurface
from core.pipeline import FlattenSettings, flatten
from core.region import Region, cover_for
from tests.test_meshsurf import _overlaps, grid_mesh, hole, panel


def cases():
    g = np.linspace(0, 1, 81)
    uv = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    C = fit_bspline(uv, panel(uv[:, 0], uv[:, 1]), 30, 30, smooth=1e-9)
    nurbs = NurbsSurface(3, 3, _clamped_knots(30), _clamped_knots(30), C)
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    circle = np.stack([0.6 + 0.15 * np.cos(t), 0.55 + 0.15 * np.sin(t)], 1)
    region = Region.from_loops([[0, 0], [1, 0], [1, 1], [0, 1]], [circle])
    V, F = grid_mesh(panel, 64, 64, hole)
    piece = mesh_surface(*clean_mesh(V, F, "panel")[:2])
    return [("NURBS, (u, v) hole", nurbs, region), ("mesh 64, hole", piece.surface, piece.region)]


def main() -> int:
    print("| case | spacing | boundary % | area % | max shear deg | overlapping node pairs | nodes |")
    print("|---|---|---|---|---|---|---|")
    shapes = cases()
    for sp in (0.02, 0.027, 0.035):
        for name, surface, region in shapes:
            cover = cover_for(surface, region)
            res = flatten(surface, FlattenSettings(spacing=sp, region=region, seed=cover.default_seed),
                          area=cover.area)
            m = res.metrics
            print(f"| {name} | {sp} | {m['boundary_error_pct']:.2f} | {m['area_error_pct']:.2f} | "
                  f"{m['max_shear_deg']:.1f} | {_overlaps(res, sp)} | {m['nodes']} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
