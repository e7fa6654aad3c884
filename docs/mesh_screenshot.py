"""Make docs/images/mesh_deviation.png: a mesh opened in the window, its fit's deviation.

    xvfb-run -s '-screen 0 1600x1000x24' .venv/bin/python docs/mesh_screenshot.py [OUT.png]

Writes a binary STL of a garment-like panel (a bulging front over a curved
body, the shape of tests/test_meshsurf.py), opens it with File > Open's code
path, solves it, turns on View > Mesh fit deviation and View > Mesh beside the
surface (the mesh, coloured by each vertex's distance to the fitted surface,
beside the surface and its cloth) and grabs the window.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import trimesh

from docs.shotkit import Shot

REPO = Path(__file__).resolve().parent.parent


def panel_mesh(nu: int = 50, nv: int = 70):
    u, v = np.meshgrid(np.linspace(0, 1, nu), np.linspace(0, 1, nv), indexing="ij")
    u, v = u.ravel(), v.ravel()
    idx = np.arange(nu * nv).reshape(nu, nv)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    F = np.r_[np.stack([a, b, c], 1), np.stack([a, c, d], 1)]
    x, y = 0.5 * u, 0.7 * v
    V = np.stack([x, y, 0.25 * np.sin(np.pi * u) * (0.6 + 0.4 * np.sin(np.pi * v)) + 0.08 * u * v], 1)
    return V, F


def main() -> int:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "docs/images/mesh_deviation.png"
    shot = Shot()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "panel.stl"
        path.write_bytes(trimesh.Trimesh(*panel_mesh(), process=False).export(file_type="stl"))
        win = shot.window(path)
        shot.solve(win)
        win.actions["show_fit_deviation"].trigger()
        win.actions["show_fit_mesh"].trigger()
        win.pattern_view.fit()
        shot.settle(1.0)
        shot.save(win.grab(), out)
        print(f"wrote {out}: {win.metrics.text('fit')}")
        win.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
