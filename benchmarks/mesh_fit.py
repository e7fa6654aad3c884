"""How long a triangle mesh takes to become a surface, and how closely it follows the mesh (issue 22:
under 10 s at 100,000 triangles).

Measured by ``benchmarks/suite.py`` (case ``mesh_fit``): a garment-like panel
with an arm hole and a sphere cap are tessellated (a grid of about
``triangles`` triangles), written as a binary STL (trimesh) to a temporary
folder, and opened with ``flatweave.reading.registry.open_path`` the way the CLI does: read
(header check and trimesh), repair and checks (``clean_mesh``), the conformal
map (``lscm``) and the fit (``fit_bspline``, refined to ``FIT_TOL``). The
fit's largest deviation is a percentage of the mesh's bounding-box diagonal.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np


def grid_mesh(f, nu, nv, keep=None):
    u, v = np.meshgrid(np.linspace(0, 1, nu), np.linspace(0, 1, nv), indexing="ij")
    u, v = u.ravel(), v.ravel()
    idx = np.arange(nu * nv).reshape(nu, nv)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    F = np.r_[np.stack([a, b, c], 1), np.stack([a, c, d], 1)]
    if keep is not None:
        F = F[keep(u[F].mean(axis=1), v[F].mean(axis=1))]
    used = np.unique(F)
    return f(u[used], v[used]), np.searchsorted(used, F)


def panel(u, v):
    x, y = 0.5 * u, 0.7 * v
    return np.stack([x, y, 0.25 * np.sin(np.pi * u) * (0.6 + 0.4 * np.sin(np.pi * v)) + 0.08 * u * v], 1)


def sphere_cap(u, v):
    x, y = 1.2 * (u - 0.5), 1.2 * (v - 0.5)
    return np.stack([x, y, np.sqrt(1 - x * x - y * y)], 1)


SHAPES = {"panel with a hole": (panel, lambda u, v: (u - 0.6) ** 2 + (v - 0.55) ** 2 > 0.15 ** 2, 1.0),
          "sphere cap": (sphere_cap, lambda u, v: (u - 0.5) ** 2 + (v - 0.5) ** 2 < 0.25, 4 / np.pi)}


def measure(triangles: int) -> dict:
    """Both shapes at about ``triangles`` triangles, each opened once; ``seconds`` is the slower."""
    import trimesh

    from flatweave.reading.registry import open_path

    out = {}
    with tempfile.TemporaryDirectory(prefix="mesh_fit_") as tmp:
        for key, (f, keep, factor) in zip(("panel", "cap"), SHAPES.values()):
            n = int(round(np.sqrt(triangles * factor / 2))) + 1
            V, F = grid_mesh(f, n, n, keep)
            path = Path(tmp) / f"{key}.stl"
            path.write_bytes(trimesh.Trimesh(V, F, process=False).export(file_type="stl"))
            t0 = time.perf_counter()
            opened = open_path(path)
            out[f"{key}_s"] = time.perf_counter() - t0
            fit = opened.surface.fit
            out[f"{key}_dev"] = 100 * fit.max_deviation / fit.size
            out[f"{key}_triangles"] = fit.triangles
    return {"seconds": max(out["panel_s"], out["cap_s"]), "panel_s": out["panel_s"], "cap_s": out["cap_s"],
            "max_dev_pct": max(out["panel_dev"], out["cap_dev"]),
            "triangles": float(max(out["panel_triangles"], out["cap_triangles"]))}
