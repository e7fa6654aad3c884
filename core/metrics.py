"""Deformation measures of a draped mesh, defined exactly.

* strain of a spring: (l - r) / r, l its chord length on the surface, r its
  rest length; thread strain is the strain of weft and warp springs.
* shear angle of a cell: 90 degrees minus the angle between its weft and warp
  edges on the surface, at each of its four corners, averaged. The edges are
  taken in the lattice's +j (weft) and +i (warp) directions at every corner,
  so a cell sheared into a parallelogram has the same signed angle at all four
  corners; positive when the weft and warp close up (angle below 90 degrees).
"""

from __future__ import annotations

import numpy as np

from core.mesh import DIAG, SpringMesh

__all__ = ["spring_lengths", "spring_strain", "cell_shear_deg", "deformation_summary"]


def spring_lengths(xyz: np.ndarray, mesh: SpringMesh) -> np.ndarray:
    """(m,) chord lengths of the springs for nodes at xyz : (n, 3)."""
    return np.linalg.norm(xyz[mesh.ends[:, 0]] - xyz[mesh.ends[:, 1]], axis=1)


def spring_strain(xyz: np.ndarray, mesh: SpringMesh) -> np.ndarray:
    """(m,) strain (l - r) / r of every spring."""
    return spring_lengths(xyz, mesh) / mesh.rest - 1.0


def cell_shear_deg(xyz: np.ndarray, mesh: SpringMesh) -> np.ndarray:
    """(c,) signed shear angle of every cell, degrees."""
    if len(mesh.cells) == 0:
        return np.zeros(0)
    p0, p1, p2, p3 = (xyz[mesh.cells[:, c]] for c in range(4))
    # (weft edge, warp edge) at corners 0..3, both pointing along +j / +i
    pairs = ((p1 - p0, p3 - p0), (p1 - p0, p2 - p1), (p2 - p3, p2 - p1), (p2 - p3, p3 - p0))
    total = np.zeros(len(mesh.cells))
    for w, p in pairs:
        cos = np.einsum("ij,ij->i", w, p) / (np.linalg.norm(w, axis=1) * np.linalg.norm(p, axis=1))
        total += 90.0 - np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    return total / 4.0


def deformation_summary(xyz: np.ndarray, mesh: SpringMesh) -> dict:
    """Thread strain and cell shear statistics (percent and degrees)."""
    strain = spring_strain(xyz, mesh)
    thread = mesh.kind != DIAG
    ts = np.abs(strain[thread])
    shear = np.abs(cell_shear_deg(xyz, mesh))
    return {
        "max_thread_strain_pct": float(100 * ts.max(initial=0.0)),
        "mean_thread_strain_pct": float(100 * ts.mean()) if ts.size else 0.0,
        "max_diag_strain_pct": float(100 * np.abs(strain[~thread]).max(initial=0.0)),
        "max_shear_deg": float(shear.max(initial=0.0)),
        "mean_shear_deg": float(shear.mean()) if shear.size else 0.0,
        "p95_shear_deg": float(np.percentile(shear, 95)) if shear.size else 0.0,
    }
