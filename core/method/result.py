"""A flattened piece (:class:`FlattenResult`), its metrics and verdicts, and its result file.

The result file (``flatten --out``, format ``flatweave-result``, :func:`result_to_dict`) is JSON.
Version 2 (issue 44) holds the per-node, per-spring and per-cell arrays compactly, each an
object ``{"dtype", "shape", "zlib_base64"}`` (:func:`flatweave.files.encode_array`; read with
:func:`flatweave.files.decode_array` or numpy, zlib and base64 alone): ``nodes.ij`` (int32),
``nodes.uv``, ``nodes.xyz``, ``nodes.xy``, ``springs.rest`` (float64), ``springs.ends``,
``cells.corners`` (int32), ``springs.kind`` (uint8, an index into ``springs.kind_names``),
and what is measured from the others in float32 (``springs.length``, ``springs.strain``,
``cells.shear_deg``). Version 1 held them as JSON lists (and ``springs.kind`` as names); its
files are read as before. A project keeps less of a result (:func:`result_state_dict`): what
rebuilds it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial import cKDTree

from flatweave.version import __version__
from flatweave.files import encode_array
from flatweave.geometry.coverage import cell_diagonal, coverage_grid, uncovered_regions
from flatweave.method.darts import DartSet
from flatweave.method.energy import Energy
from flatweave.geometry.numerics import outline_errors
from flatweave.method.lattice import KIND_NAMES, SpringMesh
from flatweave.method.metrics import (Verdict, area_beyond_lock_pct, cell_areas, cell_shear_deg, deformation_summary,
                                      judge, metric_limits, spring_lengths)
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.method.pattern import Pattern
from flatweave.geometry.quadrature import boundary_length, region_area
from flatweave.geometry.region import Cover, cover_for, region_record
from flatweave.method.solver import SolveResult, State
from flatweave.method.settings import FlattenSettings, settings_to_dict, validate_settings  # SPLIT


@dataclass(frozen=True)
class FlattenResult:
    """A flattened piece.

    mesh : SpringMesh; uv : (n, 2); xyz : (n, 3) nodes on the surface
    pattern : the 2D pattern (nodes' xy and outline)
    metrics : dict (see :func:`compute_metrics`)
    drape_stats : dict from the drape; solve : SolveResult or None
    history : the energy EN after each solver iteration (kept in project files,
        so it outlives ``solve``, which is not saved)
    warnings : one-line warnings about the result, every metric past its
        warning limit and a solve that stopped early (:func:`judge_result`,
        :func:`flatweave.method.metrics.judge`); empty when all is within limits
    status : the solver's status and what the numbers say of the pattern:
        ``"converged"``, ``"converged, with warnings"``, ``"converged, pattern
        not usable: boundary error 262 %"`` (:class:`flatweave.method.metrics.Verdict`)
    """

    surface: NurbsSurface
    settings: FlattenSettings
    mesh: SpringMesh
    uv: np.ndarray
    xyz: np.ndarray
    pattern: Pattern
    metrics: dict
    drape_stats: dict = field(default_factory=dict)
    solve: SolveResult | None = None
    history: tuple = ()
    warnings: tuple[str, ...] = ()
    status: str = ""

    @property
    def usable(self) -> bool:
        """False when a metric is past its bad limit (the status says which)."""
        return ", pattern not usable: " not in self.status

    def state(self) -> State:
        """The mesh state, to warm-start another solve."""
        return State(self.mesh, self.uv)


def compute_metrics(surface: NurbsSurface, mesh: SpringMesh, xyz: np.ndarray, pattern: Pattern,
                    yarns=(), L3: float | None = None, A3: float | None = None,
                    cover: Cover | None = None) -> dict:
    """Energy, boundary and area errors (:func:`flatweave.geometry.numerics.outline_errors`: L3
    and A3 the region's boundary length and area (``cover``'s; default the
    whole surface's), L2 and A2 the outline's), thread strain, shear and sizes."""
    trimmed = cover is not None and cover.trimmed
    if L3 is None:
        L3 = cover.boundary_length if trimmed else boundary_length(surface)
    if A3 is None:
        A3 = cover.area if trimmed else region_area(surface)
    m = {"energy": Energy(surface, mesh, yarns).value_xyz(xyz),
         **outline_errors(pattern.perimeter, L3, pattern.area, A3)}
    m.update(deformation_summary(xyz, mesh))
    m.update(coverage_metrics(surface, xyz, mesh.r_weft, mesh.r_warp, cover if trimmed else None))
    m["total_curvature"] = (cover if cover is not None else cover_for(surface)).total_curvature
    m["nodes"] = mesh.n_nodes
    m["springs"] = mesh.n_springs
    m["cells"] = int(len(mesh.cells))
    return m


def coverage_metrics(surface: NurbsSurface, xyz: np.ndarray, r_weft: float, r_warp: float,
                     cover: Cover | None = None) -> dict:
    """``uncovered_pct``: 100 x the share of the region's area farther than a
    cell diagonal from every node (:mod:`flatweave.geometry.coverage`), and
    ``max_gap_spacings``: the largest distance from a point of the region to
    the nearest node, in spacings (max(r_weft, r_warp)); about half a diagonal
    when the mesh covers the region, half the width of the widest gap when not."""
    reach = cell_diagonal(r_weft, r_warp)
    grid = coverage_grid(surface, reach) if cover is None else cover.coverage_grid(reach)
    d = cKDTree(xyz).query(grid.xyz)[0]
    if grid.inside is not None:  # a trimmed region: only its samples
        d = d[grid.inside]
        grid_area = grid.area[grid.inside]
    else:
        grid_area = grid.area
    far = d > reach
    total = float(grid_area.sum())
    return {"uncovered_pct": float(100 * grid_area[far].sum() / total) if total > 0 else 0.0,
            "max_gap_spacings": float(d.max(initial=0.0) / max(r_weft, r_warp))}


def judge_result(result: "FlattenResult", warn_deg: float | None = None,
                 lock_deg: float | None = None) -> Verdict:
    """The result's :class:`~flatweave.method.metrics.Verdict` (:func:`flatweave.method.metrics.judge`)
    against :func:`flatweave.method.metrics.metric_limits` of its material, its piece's
    curvature and the shear angles (the material's unless given: the window
    gives the project's display angles)."""
    limits = metric_limits(result.settings.material, warn_deg, lock_deg,
                           total_curvature=result.metrics.get("total_curvature"))
    return judge(result.metrics, result.settings, limits,
                 shear=(cell_shear_deg(result.xyz, result.mesh), cell_areas(result.xyz, result.mesh)))


def judged(result: "FlattenResult") -> "FlattenResult":
    """``result`` with the warnings and status of its :func:`judge_result`."""
    v = judge_result(result)
    return replace(result, warnings=v.warnings, status=v.status)


def with_shear_angles(result: "FlattenResult", warn_deg: float, lock_deg: float) -> "FlattenResult":
    """``result`` judged by a material with other shear angles: the same solve
    (the angles do not enter the energy), with the settings, the mesh's
    material, the share of the area beyond the lock angle and the warnings of
    the new angles (raises SettingsError for angles a material cannot have)."""
    material = replace(result.settings.material, warn_deg=float(warn_deg), lock_deg=float(lock_deg))
    settings = replace(result.settings, material=material)
    validate_settings(settings)
    mesh = replace(result.mesh, material=material)
    shear, areas = cell_shear_deg(result.xyz, mesh), cell_areas(result.xyz, mesh)
    metrics = {**result.metrics, "area_beyond_lock_pct": area_beyond_lock_pct(np.abs(shear), areas, material.lock_deg)}
    return judged(replace(result, settings=settings, mesh=mesh, metrics=metrics))


RESULT_VERSION = 2


def result_state_dict(result: FlattenResult) -> dict:
    """What of a result rebuilds it (a project's saved result, :func:`flatweave.document.project.result_from_dict`):
    the settings, metrics, drape statistics, warnings and status, and the nodes' lattice positions and (u, v)
    and the springs' ends (encoded as in the result file); the rest is recomputed from them."""
    mesh = result.mesh
    return {
        "format": "flatweave-result",
        "version": RESULT_VERSION,
        "flatweave": __version__,
        "settings": settings_to_dict(result.settings, "result"),
        "metrics": result.metrics,
        "drape": result.drape_stats,
        "nodes": {"ij": encode_array(mesh.ij, "<i4"), "uv": encode_array(result.uv, "<f8")},
        "springs": {"ends": encode_array(mesh.ends, "<i4")},
        "status": result.status,
        "warnings": list(result.warnings),
    }


def result_to_dict(result: FlattenResult, surface_source: str | None = None) -> dict:
    """The result file's content (see the module docstring and README, "Result file")."""
    mesh, xyz, pattern = result.mesh, result.xyz, result.pattern
    length = spring_lengths(xyz, mesh)
    return {
        "format": "flatweave-result",
        "version": RESULT_VERSION,
        "flatweave": __version__,
        "surface": surface_source,
        "settings": settings_to_dict(result.settings, "result"),
        "metrics": result.metrics,
        "drape": result.drape_stats,
        "nodes": {
            "ij": encode_array(mesh.ij, "<i4"),
            "uv": encode_array(result.uv, "<f8"),
            "xyz": encode_array(xyz, "<f8"),
            "xy": encode_array(pattern.xy, "<f8"),
        },
        "springs": {
            "ends": encode_array(mesh.ends, "<i4"),
            "kind": encode_array(mesh.kind, "|u1"),
            "kind_names": list(KIND_NAMES),
            "rest": encode_array(mesh.rest, "<f8"),
            "length": encode_array(length, "<f4"),
            "strain": encode_array(length / mesh.rest - 1.0, "<f4"),
        },
        "cells": {
            "corners": encode_array(mesh.cells, "<i4"),
            "shear_deg": encode_array(cell_shear_deg(xyz, mesh), "<f4"),
        },
        "pattern": {
            "outline": pattern.outline.tolist(),
            "outline3d": pattern.outline3d.tolist(),
            "outline_uv": pattern.outline_uv.tolist(),
            "on_boundary": pattern.on_boundary.tolist() if pattern.on_boundary is not None else None,
            "pieces": [pc.to_dict() for pc in pattern.pieces],
        },
        "darts": _darts_dict(result),
        # the piece's region: loops in (u, v) and on the surface, and how it was drawn (null: whole domain)
        "region": region_record(result.surface, result.settings.region) if result.settings.region is not None
        else None,
        "uncovered_regions": [g.to_dict() for g in uncovered_regions(
            result.surface, xyz, cell_diagonal(mesh.r_weft, mesh.r_warp),
            grid=cover_for(result.surface, result.settings.region).coverage_grid(
                cell_diagonal(mesh.r_weft, mesh.r_warp)) if result.settings.region is not None else None)]
        if result.metrics.get("uncovered_pct") else [],
        "status": result.status,
        "warnings": list(result.warnings),
    }


_OPENING_DART_KEYS = ("kind", "name", "plane", "box", "auto")  # a result's dart openings: no curve points


def _darts_dict(result: FlattenResult) -> list[dict]:
    """The darts: definition, curve, leg lengths, opening angle, dart nodes."""
    s = result.settings
    if not s.darts:
        return []
    reach = float(np.hypot(result.mesh.r_weft, result.mesh.r_warp))
    labels = DartSet(result.surface, s.darts).dart_nodes(
        [o.curve3d for o in result.pattern.darts], result.uv, result.xyz, reach)
    out = []
    for dart, opening, nodes in zip(s.darts, result.pattern.darts, labels):
        entry = dart.to_dict(_OPENING_DART_KEYS)
        entry.update({
            "curve_uv": opening.curve_uv.tolist(), "curve": opening.curve3d.tolist(),
            "mouth_on_boundary": opening.mouth,
            "leg_lengths": list(opening.leg_lengths), "opening_deg": opening.opening_deg,
            "positive_nodes": nodes["positive"].tolist(), "negative_nodes": nodes["negative"].tolist(),
        })
        out.append(entry)
    return out
