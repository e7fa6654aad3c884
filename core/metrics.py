"""Deformation measures of a draped mesh, defined exactly.

* strain of a spring: (l - r) / r, l its chord length on the surface, r its
  rest length; thread strain is the strain of weft and warp springs.
* shear angle of a cell: 90 degrees minus the angle between its weft and warp
  edges on the surface, at each of its four corners, averaged. The edges are
  taken in the lattice's +j (weft) and +i (warp) directions at every corner,
  so a cell sheared into a parallelogram has the same signed angle at all four
  corners; positive when the weft and warp close up (angle below 90 degrees).

Limits and warnings. :func:`metric_limits` gives, per metric key, the
(warning, bad) thresholds a result is judged by (the window colours every
metric with them), and :func:`result_warnings` turns a result's metrics into
one-line warnings (``FlattenResult.warnings``, the result file's
``warnings``, the CLI's ``flatweave: warning: ...`` lines). The numbers and
why are in docs/decisions.md ("Limits of a plausible result").
"""

from __future__ import annotations

import numpy as np

from core.mesh import DIAG, Material, SpringMesh

__all__ = ["spring_lengths", "spring_strain", "cell_shear_deg", "cell_areas", "deformation_summary",
           "area_beyond_lock_pct",
           "is_woven", "metric_limits", "result_warnings", "LIMIT_KEYS", "WOVEN_STRAIN_PCT",
           "SHEET_STRAIN_PCT", "MANY_DELETED_PCT"]


def spring_lengths(xyz: np.ndarray, mesh: SpringMesh) -> np.ndarray:
    """(m,) chord lengths of the springs for nodes at xyz : (n, 3)."""
    # rows gathered by np.take: several times quicker than fancy indexing at (n, 3)
    return np.linalg.norm(np.take(xyz, mesh.ends[:, 0], axis=0) - np.take(xyz, mesh.ends[:, 1], axis=0), axis=1)


def spring_strain(xyz: np.ndarray, mesh: SpringMesh) -> np.ndarray:
    """(m,) strain (l - r) / r of every spring."""
    return spring_lengths(xyz, mesh) / mesh.rest - 1.0


def cell_shear_deg(xyz: np.ndarray, mesh: SpringMesh) -> np.ndarray:
    """(c,) signed shear angle of every cell, degrees."""
    if len(mesh.cells) == 0:
        return np.zeros(0)
    p0, p1, p2, p3 = (np.take(xyz, mesh.cells[:, c], axis=0) for c in range(4))
    # (weft edge, warp edge) at corners 0..3, both pointing along +j / +i
    pairs = ((p1 - p0, p3 - p0), (p1 - p0, p2 - p1), (p2 - p3, p2 - p1), (p2 - p3, p3 - p0))
    total = np.zeros(len(mesh.cells))
    for w, p in pairs:
        cos = np.einsum("ij,ij->i", w, p) / (np.linalg.norm(w, axis=1) * np.linalg.norm(p, axis=1))
        total += 90.0 - np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    return total / 4.0


def area_beyond_lock_pct(shear_deg: np.ndarray, areas: np.ndarray, lock_deg: float) -> float:
    """100 x the share of the covered area (the cells' areas summed) whose
    cell shear passes ``lock_deg`` in magnitude; 0 for no cells."""
    a = np.asarray(areas, dtype=float)
    total = float(a.sum())
    if not total > 0:
        return 0.0
    return float(100.0 * a[np.abs(np.asarray(shear_deg, dtype=float)) > lock_deg].sum() / total)


def deformation_summary(xyz: np.ndarray, mesh: SpringMesh) -> dict:
    """Thread strain and cell shear statistics (percent and degrees); the
    share of the area beyond the material's lock angle."""
    strain = spring_strain(xyz, mesh)
    thread = mesh.kind != DIAG
    ts = np.abs(strain[thread])
    shear = np.abs(cell_shear_deg(xyz, mesh))
    return {
        "area_beyond_lock_pct": area_beyond_lock_pct(shear, cell_areas(xyz, mesh), mesh.material.lock_deg),
        "max_thread_strain_pct": float(100 * ts.max(initial=0.0)),
        "mean_thread_strain_pct": float(100 * ts.mean()) if ts.size else 0.0,
        "max_diag_strain_pct": float(100 * np.abs(strain[~thread]).max(initial=0.0)),
        "max_shear_deg": float(shear.max(initial=0.0)),
        "mean_shear_deg": float(shear.mean()) if shear.size else 0.0,
        "p95_shear_deg": float(np.percentile(shear, 95)) if shear.size else 0.0,
    }


def cell_areas(xyz: np.ndarray, mesh: SpringMesh) -> np.ndarray:
    """(c,) area of every cell on the surface (its two triangles across the 0-2 diagonal)."""
    if len(mesh.cells) == 0:
        return np.zeros(0)
    p0, p1, p2, p3 = (np.take(xyz, mesh.cells[:, c], axis=0) for c in range(4))
    return 0.5 * (np.linalg.norm(np.cross(p1 - p0, p2 - p0), axis=1)
                  + np.linalg.norm(np.cross(p2 - p0, p3 - p0), axis=1))


# ------------------------------------------------------------------ limits and warnings
WOVEN_STRAIN_PCT = (1.0, 3.0)
"""(warning, bad) thread strain of woven cloth, percent: its threads are near-inextensible."""

SHEET_STRAIN_PCT = (10.0, 25.0)
"""(warning, bad) strain of an isotropic sheet (knit, non-woven, membrane), percent."""

UNCOVERED_PCT = (0.5, 2.0)
"""(warning, bad) share of the region the cloth leaves uncovered, percent."""

MANY_DELETED_PCT = (10.0, 30.0)
"""(warning, bad) nodes deleted during a solve, percent of the drape's nodes."""

BEYOND_LOCK_PCT = (0.5, 5.0)
"""(warning, bad) share of the area sheared past the lock angle, percent (as much as a few corner cells is fine)."""

BOUNDARY_ERROR_PCT = (5.0, 10.0)
AREA_ERROR_PCT = (2.0, 5.0)

LIMIT_KEYS = ("uncovered_pct", "max_thread_strain_pct", "max_shear_deg", "area_beyond_lock_pct",
              "boundary_error_pct", "area_error_pct", "nodes_deleted_pct")
"""The metric keys :func:`metric_limits` gives thresholds for, in this order."""

_WOVEN_RATIO = 0.1


def is_woven(material: Material) -> bool:
    """A material judged as woven cloth: its threads are at least ten times
    stiffer than its diagonals (both presets and any ratio WEFT:WARP:DIAG)."""
    return material.k_diag <= _WOVEN_RATIO * min(material.k_weft, material.k_warp)


def metric_limits(material: Material, warn_deg: float | None = None,
                  lock_deg: float | None = None) -> dict[str, tuple[float, float]]:
    """Per metric key (:data:`LIMIT_KEYS`) the (warning, bad) thresholds:
    a value at or below the first is fine, above it a warning, above the
    second bad. The shear thresholds are the material's warning and lock
    angles unless given (the window passes the project's display angles,
    ``Project.shear_warning_deg``, ``shear_limit_deg``); the thread strain's
    depend on the material (:func:`is_woven`)."""
    warn_deg = material.warn_deg if warn_deg is None else warn_deg
    lock_deg = material.lock_deg if lock_deg is None else lock_deg
    if not (np.isfinite(warn_deg) and np.isfinite(lock_deg) and 0 < warn_deg < lock_deg):
        raise ValueError(f"shear angles must be 0 < warning < lock, got {warn_deg!r} and {lock_deg!r}")
    return {
        "uncovered_pct": UNCOVERED_PCT,
        "max_thread_strain_pct": WOVEN_STRAIN_PCT if is_woven(material) else SHEET_STRAIN_PCT,
        "max_shear_deg": (float(warn_deg), float(lock_deg)),
        "area_beyond_lock_pct": BEYOND_LOCK_PCT,
        "boundary_error_pct": BOUNDARY_ERROR_PCT,
        "area_error_pct": AREA_ERROR_PCT,
        "nodes_deleted_pct": MANY_DELETED_PCT,
    }


def _num(metrics: dict, key: str) -> float | None:
    v = metrics.get(key)
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) else None


def result_warnings(metrics: dict, settings, limits: dict[str, tuple[float, float]],
                    shear: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[str, ...]:
    """One-line warnings about a result, from its ``metrics`` (as
    ``FlattenResult.metrics``), its ``settings`` (a FlattenSettings: darts,
    yarns and material say what to do) and ``limits``
    (:func:`metric_limits`); an empty tuple for a result within them all.

    shear : (cell shear (c,) degrees, cell areas (c,)) of the result, for the
    share of the area beyond the lock angle (:func:`cell_shear_deg`,
    :func:`cell_areas`); without it the warning gives the largest shear only.

    In order: the uncovered share, thread strain beyond the material's
    limit, shear beyond the lock angle (woven materials only: an isotropic
    sheet has no threads to lock), many nodes deleted, a budget reached, a
    stopped solve.
    """
    out = []
    darts, yarns = tuple(getattr(settings, "darts", ())), tuple(getattr(settings, "yarns", ()))
    material = getattr(settings, "material", None)
    woven = material is None or is_woven(material)
    unc = _num(metrics, "uncovered_pct")
    if unc is not None and unc > limits["uncovered_pct"][0]:
        gap = _num(metrics, "max_gap_spacings")
        far = f", parts of it {gap:.1f} spacings from the nearest node" if gap is not None else ""
        text = f"{unc:.1f} % of the surface is not covered by the cloth{far}: "
        if darts:
            text += ("if it is the wedge between a dart's two sides (on negative curvature the cloth is short "
                     "of material, the cut lets the sides pull apart and no lattice positions are left between "
                     "them), it needs an inserted piece (a gusset), not a dart: the result's uncovered_regions "
                     "give its outline; otherwise try another seed or a smaller spacing")
        else:
            text += ("the threads cannot reach it from this seed; try another seed or a smaller spacing, "
                     "or split the surface there")
        out.append(text)
    strain = _num(metrics, "max_thread_strain_pct")
    lim = limits["max_thread_strain_pct"][0]
    if strain is not None and strain > lim:
        what = "woven cloth's near-inextensible threads" if woven else "an isotropic sheet"
        why = ("; a yarn held to a plane the threads cannot follow does this: check the yarn constraints"
               if yarns else "; the surface needs darts there, or another material")
        out.append(f"thread strain up to {strain:.3g} %, beyond the {lim:g} % {what} plausibly take"
                   f"{'' if woven else 's'}{why}")
    smax = _num(metrics, "max_shear_deg")
    lock = limits["max_shear_deg"][1]
    if woven and smax is not None and smax > lock:
        where = ""
        if shear is not None and len(shear[0]):
            a = np.asarray(shear[1], dtype=float)
            beyond = np.abs(np.asarray(shear[0], dtype=float)) > lock
            where = f" on {100 * a[beyond].sum() / max(a.sum(), 1e-300):.1f} % of the area"
        out.append(f"shear up to {smax:.1f} deg, beyond the lock angle of {lock:g} deg{where}: the cloth "
                   f"cannot shear that far without wrinkling; add a dart there")
    deleted, pct = _num(metrics, "nodes_deleted"), _num(metrics, "nodes_deleted_pct")
    if deleted is not None and pct is not None and pct > limits["nodes_deleted_pct"][0]:
        refilled = int(_num(metrics, "nodes_refilled") or 0)
        out.append(f"{int(deleted):,} nodes deleted during the solve ({pct:.0f} % of the drape's), "
                   f"{refilled:,} refilled: the mesh slid over the region; check its coverage and the pattern's edge")
    status = metrics.get("solver_status")
    if isinstance(status, str) and status.startswith("stopped at the"):
        out.append(f"the solve {status} before it converged: raise the budget, or run again from this result")
    elif isinstance(status, str) and status.startswith("stopped"):
        out.append(f"the solve was {status} before it converged: the result is its last iterate")
    return tuple(out)
