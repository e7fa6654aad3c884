"""The hole in the drape: a doubly curved panel with an arm hole (the garment panel of
tests/test_meshsurf.py), as a NURBS with a (u, v) hole and as a 64 x 64 mesh, flattened at three
spacings: errors, largest shear, and the node pairs that lie on each other (closer than half a
spacing on the surface, more than two lattice steps apart). Run from the repository root:

    .venv/bin/python benchmarks/hole_drape.py [--bundled]

``--bundled``: the bundled surfaces instead, each with a (u, v) hole (a circle of radius 0.15 of
the domain at (0.6, 0.55)), at its recommended spacing, with and without the hole.

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


def bundled() -> None:
    from core.examples import example_info, example_names
    from core.readers import open_path

    print("| surface | spacing | hole: boundary / area % | overlapping pairs | no hole: boundary / area % |")
    print("|---|---|---|---|---|")
    t = np.linspace(0, 2 * np.pi, 120, endpoint=False)
    for name in sorted(example_names()):
        s = open_path(name).surface
        (u0, u1), (v0, v1) = s.domain
        square = [[u0, v0], [u1, v0], [u1, v1], [u0, v1]]
        circle = np.stack([u0 + (u1 - u0) * (0.6 + 0.15 * np.cos(t)), v0 + (v1 - v0) * (0.55 + 0.15 * np.sin(t))], 1)
        sp = example_info(name)["recommended_spacing"]
        out = []
        for region in (Region.from_loops(square, [circle]), None):
            cover = cover_for(s, region)
            res = flatten(s, FlattenSettings(spacing=sp, region=region, seed=cover.default_seed), area=cover.area)
            out.append((res.metrics["boundary_error_pct"], res.metrics["area_error_pct"], _overlaps(res, sp)))
        (b1, a1, n1), (b0, a0, _) = out
        print(f"| {name} | {sp} | {b1:.2f} / {a1:.2f} | {n1} | {b0:.2f} / {a0:.2f} |", flush=True)


def main() -> int:
    if "--bundled" in sys.argv[1:]:
        bundled()
        return 0
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
