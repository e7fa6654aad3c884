"""Deformation measures of a draped mesh, defined exactly.

* strain of a spring: (l - r) / r, l its chord length on the surface, r its
  rest length; thread strain is the strain of weft and warp springs.
* shear angle of a cell: 90 degrees minus the angle between its weft and warp
  edges on the surface, at each of its four corners, averaged. The edges are
  taken in the lattice's +j (weft) and +i (warp) directions at every corner,
  so a cell sheared into a parallelogram has the same signed angle at all four
  corners; positive when the weft and warp close up (angle below 90 degrees).

Limits and judgement. :func:`metric_limits` gives, per metric key, the
(warning, bad) thresholds a result is judged by (the window colours every
metric with them), and :func:`judge` turns a result's metrics into its
:class:`Verdict`: one-line warnings (``FlattenResult.warnings``, the result
file's ``warnings``, the CLI's ``flatweave: warning: ...`` lines, the window's
Warnings cell) and the status (``converged, pattern not usable: ...`` past a
bad limit). Why the numbers are what they are:
docs/decisions/0018-metric-limits-and-one-judgement.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flatweave.method.lattice import DIAG, Material, SpringMesh

__all__ = ["spring_lengths", "spring_strain", "cell_shear_deg", "cell_areas", "deformation_summary",
           "area_beyond_lock_pct",
           "is_woven", "metric_limits", "judge", "Verdict", "curvature_error_pct", "LIMIT_KEYS",
           "WOVEN_STRAIN_PCT", "SHEET_STRAIN_PCT", "MANY_DELETED_PCT"]


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


# ------------------------------------------------------------------ limits and judgement
WOVEN_STRAIN_PCT = (1.0, 3.0)
"""(warning, bad) thread strain of woven cloth, percent: its threads are near-inextensible."""

SHEET_STRAIN_PCT = (10.0, 25.0)
"""(warning, bad) strain of an isotropic sheet (knit, non-woven, membrane), percent."""

UNCOVERED_PCT = (0.5, 2.0)
"""(warning, bad) share of the region the cloth leaves uncovered, percent."""

MANY_DELETED_PCT = (10.0, math.inf)
"""(warning, bad) nodes deleted during a solve, percent of the drape's nodes: a warning only (the
coverage and the outline's errors say whether the pattern suffered)."""

BEYOND_LOCK_PCT = (0.5, 5.0)
"""(warning, bad) share of the area sheared past the lock angle, percent (as much as a few corner cells is fine)."""

BOUNDARY_ERROR_PCT = (5.0, 10.0)
"""(warning, bad) boundary error, percent, of a piece with little curvature (the floors of its limits)."""

AREA_ERROR_PCT = (2.0, 5.0)
"""(warning, bad) area error, percent, of a piece with little curvature (the floors of its limits)."""

BOUNDARY_PER_CURVATURE = (1.5, 3.0)
"""(warning, bad) boundary error as multiples of :func:`curvature_error_pct`: good patterns of the
bundled pieces measure 0.6-1.1 times it (docs/decisions/0018-metric-limits-and-one-judgement.md)."""

AREA_PER_CURVATURE = (0.5, 1.0)
"""(warning, bad) area error as multiples of :func:`curvature_error_pct` (good patterns: at most 0.3 times)."""

ERROR_CEILING_PCT = {"boundary_error_pct": (25.0, 50.0), "area_error_pct": (10.0, 20.0)}
"""The highest (warning, bad) limits of the outline's errors, however curved the piece: a pattern a
quarter longer round its edge than the piece does not lay up as one piece."""

FIT_DEVIATION_PCT = (0.5, 2.0)
"""(warning, bad) largest distance from a mesh's vertex to the surface fitted to it, percent of the
mesh's size: beyond it the piece flattened is not the designer's shape."""

LIMIT_KEYS = ("uncovered_pct", "max_thread_strain_pct", "max_shear_deg", "area_beyond_lock_pct",
              "boundary_error_pct", "area_error_pct", "nodes_deleted_pct", "fit_max_deviation_pct")
"""The metric keys :func:`metric_limits` can give thresholds for, in the order a judgement lists them."""

_WOVEN_RATIO = 0.1


def is_woven(material: Material) -> bool:
    """A material judged as woven cloth: its threads are at least ten times
    stiffer than its diagonals (both presets and any ratio WEFT:WARP:DIAG)."""
    return material.k_diag <= _WOVEN_RATIO * min(material.k_weft, material.k_warp)


def curvature_error_pct(total_curvature: float) -> float:
    """100 |K_total| / (8 pi): the boundary error, percent, of a geodesic disc
    whose Gaussian curvature integrates to ``total_curvature``, flattened with
    its area kept.

    A disc of geodesic radius r on a surface of curvature K has perimeter
    2 pi r (1 - K r^2 / 6) and area pi r^2 (1 - K r^2 / 12) to first order; the
    plane disc of that area has perimeter 2 pi r (1 - K r^2 / 24), longer by
    K r^2 / 8 = K_total / (8 pi). The sphere's octant gives 6.25 % (the paper's
    patterns 5.4 %), the saddle z = (x^2 - y^2) / 2 on [-1, 1]^2 8.3 % (8.3 % for
    every method, REFERENCE.md), a developable piece 0."""
    k = float(total_curvature)
    return 100.0 * abs(k) / (8.0 * math.pi) if math.isfinite(k) else 0.0


def _outline_limits(key: str, total_curvature: float | None) -> tuple[float, float]:
    floor, per = ((BOUNDARY_ERROR_PCT, BOUNDARY_PER_CURVATURE) if key == "boundary_error_pct"
                  else (AREA_ERROR_PCT, AREA_PER_CURVATURE))
    scale = curvature_error_pct(total_curvature) if total_curvature is not None else 0.0
    ceiling = ERROR_CEILING_PCT[key]
    return tuple(float(min(max(f, p * scale), c)) for f, p, c in zip(floor, per, ceiling))


def metric_limits(material: Material, warn_deg: float | None = None, lock_deg: float | None = None,
                  total_curvature: float | None = None) -> dict[str, tuple[float, float]]:
    """Per metric key (:data:`LIMIT_KEYS`) the (warning, bad) thresholds:
    a value at or below the first is fine, above it a warning, above the
    second the pattern is not usable (``math.inf``: never).

    The shear thresholds are the material's warning and lock angles unless
    given (the window passes the project's display angles), and only for a
    woven material (an isotropic sheet has no threads to lock: no shear keys);
    the thread strain's depend on the material (:func:`is_woven`); the
    boundary and area errors' grow with the piece's ``total_curvature``
    (:attr:`flatweave.geometry.region.Cover.total_curvature`; None: the floors) as
    :data:`BOUNDARY_PER_CURVATURE` and :data:`AREA_PER_CURVATURE` times
    :func:`curvature_error_pct`, between the floors and :data:`ERROR_CEILING_PCT`."""
    warn_deg = material.warn_deg if warn_deg is None else warn_deg
    lock_deg = material.lock_deg if lock_deg is None else lock_deg
    if not (np.isfinite(warn_deg) and np.isfinite(lock_deg) and 0 < warn_deg < lock_deg):
        raise ValueError(f"shear angles must be 0 < warning < lock, got {warn_deg!r} and {lock_deg!r}")
    woven = is_woven(material)
    limits = {
        "uncovered_pct": UNCOVERED_PCT,
        "max_thread_strain_pct": WOVEN_STRAIN_PCT if woven else SHEET_STRAIN_PCT,
        "max_shear_deg": (float(warn_deg), float(lock_deg)),
        "area_beyond_lock_pct": BEYOND_LOCK_PCT,
        "boundary_error_pct": _outline_limits("boundary_error_pct", total_curvature),
        "area_error_pct": _outline_limits("area_error_pct", total_curvature),
        "nodes_deleted_pct": MANY_DELETED_PCT,
        "fit_max_deviation_pct": FIT_DEVIATION_PCT,
    }
    if not woven:
        del limits["max_shear_deg"], limits["area_beyond_lock_pct"]
    return limits


def _num(metrics: dict, key: str) -> float | None:
    v = metrics.get(key)
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) else None


@dataclass(frozen=True)
class Verdict:
    """What a result's numbers say about its pattern (:func:`judge`).

    warnings : one line per metric past its warning limit, and a solve that
        stopped before it converged (the CLI's ``flatweave: warning:`` lines,
        the result file's ``warnings``, the window's Warnings cell)
    unusable : a short phrase per metric past its bad limit, e.g.
        ``"boundary error 262 %"``; empty when the pattern is usable
    status : the solver's status, then ``", pattern not usable: ..."`` naming
        ``unusable``, or ``", with warnings"`` (the CLI's summary line, the
        result file's ``status``, the window's Status cell)
    """

    warnings: tuple[str, ...] = ()
    unusable: tuple[str, ...] = ()
    status: str = ""

    @property
    def usable(self) -> bool:
        return not self.unusable


def _pct(x: float) -> str:
    return f"{x:.3g} %"


def judge(metrics: dict, settings, limits: dict[str, tuple[float, float]],
          shear: tuple[np.ndarray, np.ndarray] | None = None) -> Verdict:
    """The :class:`Verdict` on a result, from its ``metrics`` (as
    ``FlattenResult.metrics``), its ``settings`` (a FlattenSettings: darts,
    yarns and material say what to advise) and ``limits``
    (:func:`metric_limits`; a key it lacks is not judged).

    shear : (cell shear (c,) degrees, cell areas (c,)) of the result, for the
    share of the area past the lock angle in the shear warning.

    Warnings in the order of :data:`LIMIT_KEYS`, then a solve that stopped
    early; ``unusable`` names every metric past its bad limit in that order.
    """
    out, bad = [], []
    darts, yarns = tuple(getattr(settings, "darts", ())), tuple(getattr(settings, "yarns", ()))
    material = getattr(settings, "material", None)
    woven = material is None or is_woven(material)

    def past(key):
        """(value, warning limit, bad?) of a metric past its warning limit, else None."""
        v, lim = _num(metrics, key), limits.get(key)
        if v is None or lim is None or not v > lim[0]:
            return None
        return v, lim[0], v > lim[1]

    hit = past("uncovered_pct")
    if hit:
        unc, lim, worse = hit
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
        if worse:
            bad.append(f"{unc:.1f} % uncovered")
    hit = past("max_thread_strain_pct")
    if hit:
        strain, lim, worse = hit
        what = "woven cloth's near-inextensible threads" if woven else "an isotropic sheet"
        why = ("; a yarn held to a plane the threads cannot follow does this: check the yarn constraints"
               if yarns else "; the surface needs darts there, or another material")
        out.append(f"thread strain up to {strain:.3g} %, beyond the {lim:g} % {what} plausibly take"
                   f"{'' if woven else 's'}{why}")
        if worse:
            bad.append(f"thread strain {_pct(strain)}")
    hit = past("max_shear_deg")
    if hit:
        smax, warn, worse = hit
        lock = limits["max_shear_deg"][1]
        if worse:
            share = _num(metrics, "area_beyond_lock_pct")
            if shear is not None and len(shear[0]):
                a = np.asarray(shear[1], dtype=float)
                beyond = np.abs(np.asarray(shear[0], dtype=float)) > lock
                share = 100 * a[beyond].sum() / max(a.sum(), 1e-300)
            where = "" if share is None else f" on {share:.1f} % of the area"
            out.append(f"shear up to {smax:.1f} deg, beyond the lock angle of {lock:g} deg{where}: the cloth "
                       f"cannot shear that far without wrinkling; add a dart there")
            bad.append(f"shear {smax:.1f} deg beyond the lock angle {lock:g} deg")
        else:
            out.append(f"shear up to {smax:.1f} deg, beyond the warning angle of {warn:g} deg (lock {lock:g} deg): "
                       f"check the cloth follows there, or add a dart")
    # the share past the lock angle: said already where the largest shear passes it
    hit = None if bad and bad[-1].startswith("shear ") else past("area_beyond_lock_pct")
    if hit:
        share, lim, worse = hit
        out.append(f"{share:.2g} % of the area is sheared past the lock angle (more than {lim:g} %): "
                   f"it will wrinkle there")
        if worse:
            bad.append(f"{share:.2g} % of the area past the lock angle")
    for key, name in (("boundary_error_pct", "boundary"), ("area_error_pct", "area")):
        hit = past(key)
        if not hit:
            continue
        value, lim, worse = hit
        signed = _num(metrics, key.replace("_pct", "_signed_pct"))
        way = "" if signed is None else (" (the pattern's larger)" if signed > 0 else " (the pattern's smaller)")
        k = _num(metrics, "total_curvature")
        why = (f"; this piece's curvature accounts for about {curvature_error_pct(k):.2g} %" if k is not None else "")
        out.append(f"{name} error {_pct(value)}{way}, beyond the {lim:.3g} % limit{why}: the pattern will not "
                   f"lay up to the piece's {'edge' if name == 'boundary' else 'area'}; add darts or split the piece")
        if worse:
            bad.append(f"{name} error {_pct(value)}")
    hit = past("nodes_deleted_pct")
    if hit:
        pct, _, _ = hit
        deleted = int(_num(metrics, "nodes_deleted") or 0)
        refilled = int(_num(metrics, "nodes_refilled") or 0)
        out.append(f"{deleted:,} nodes deleted during the solve ({pct:.0f} % of the drape's), "
                   f"{refilled:,} refilled: the mesh slid over the region; check its coverage and the pattern's edge")
    hit = past("fit_max_deviation_pct")
    if hit:
        dev, lim, worse = hit
        out.append(f"the surface fitted to the mesh is up to {_pct(dev)} of the mesh's size away from it "
                   f"(more than {lim:g} %): the piece flattened is smoother than the mesh")
        if worse:
            bad.append(f"the fitted surface {_pct(dev)} of its size off the mesh")
    status = metrics.get("solver_status")
    status = status if isinstance(status, str) and status else "no solver"
    if status.startswith("stopped at the"):
        out.append(f"the solve {status} before it converged: raise the budget, or run again from this result")
    elif status.startswith("stopped"):
        out.append(f"the solve was {status} before it converged: the result is its last iterate")
    if bad:
        status = f"{status}, pattern not usable: {', '.join(bad)}"
    elif out:
        status = f"{status}, with warnings"
    return Verdict(tuple(out), tuple(bad), status)
