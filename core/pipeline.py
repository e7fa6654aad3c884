"""One path from surface to result, shared by the CLI, the GUI and the tests.

surface -> drape -> (minimise) -> metrics -> result dictionary
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field

import numpy as np

import core
from core.drape import DrapeResult, DrapeSettings, drape
from core.energy import Energy, YarnConstraint
from core.errors import SettingsError
from core.mesh import KIND_NAMES, MATERIALS, Material, SpringMesh
from core.metrics import cell_shear_deg, deformation_summary, spring_lengths
from core.nurbs import NurbsSurface

__all__ = ["FlattenSettings", "FlattenResult", "flatten", "result_to_dict", "SOLVERS"]

SOLVERS = ("none",)


@dataclass(frozen=True)
class FlattenSettings:
    """Everything that decides a flattening, apart from the surface.

    spacing, spacing_warp : rest lengths of weft and warp springs (warp
        defaults to the weft spacing)
    material : spring constants (presets in ``core.mesh.MATERIALS``)
    seed : seed point as fractions of the parameter domain
    angle_deg : weft direction at the seed, from S_u towards S_v
    paths : constrained paths, "plane" (paper) or "geodesic"
    solver : "none" (the drape only)
    yarns : yarn constraints (directional energy)
    """

    spacing: float
    spacing_warp: float | None = None
    material: Material = MATERIALS["woven"]
    seed: tuple[float, float] = (0.5, 0.5)
    angle_deg: float = 0.0
    paths: str = "plane"
    solver: str = "none"
    yarns: tuple[YarnConstraint, ...] = ()
    max_nodes: int = 2_000_000

    def drape_settings(self) -> DrapeSettings:
        return DrapeSettings(self.spacing, self.spacing_warp, tuple(self.seed), float(self.angle_deg),
                             self.paths, self.max_nodes)


@dataclass(frozen=True)
class FlattenResult:
    """A flattened piece.

    mesh : SpringMesh; uv : (n, 2); xyz : (n, 3) nodes on the surface
    energy : EN at the result; metrics : dict (see :func:`compute_metrics`)
    drape_stats : dict from the drape
    """

    surface: NurbsSurface
    settings: FlattenSettings
    mesh: SpringMesh
    uv: np.ndarray
    xyz: np.ndarray
    metrics: dict
    drape_stats: dict = field(default_factory=dict)


def compute_metrics(surface: NurbsSurface, mesh: SpringMesh, uv: np.ndarray, xyz: np.ndarray,
                    yarns=()) -> dict:
    """Energy, thread strain, shear and sizes of a mesh state."""
    m = {"energy": Energy(surface, mesh, yarns).value_xyz(xyz)}
    m.update(deformation_summary(xyz, mesh))
    m["nodes"] = mesh.n_nodes
    m["springs"] = mesh.n_springs
    m["cells"] = int(len(mesh.cells))
    return m


def flatten(surface: NurbsSurface, settings: FlattenSettings, area: float | None = None) -> FlattenResult:
    """Drape the mesh and (with a solver) minimise its energy."""
    if settings.solver not in SOLVERS:
        raise SettingsError(f"solver {settings.solver!r} is not one of {', '.join(SOLVERS)}")
    t0 = time.perf_counter()
    d: DrapeResult = drape(surface, settings.drape_settings(), settings.material, area=area)
    metrics = compute_metrics(surface, d.mesh, d.uv, d.xyz, settings.yarns)
    metrics["seconds"] = time.perf_counter() - t0
    metrics["drape_seconds"] = d.stats["seconds"]
    return FlattenResult(surface, settings, d.mesh, d.uv, d.xyz, metrics, d.stats)


def _settings_dict(s: FlattenSettings) -> dict:
    out = asdict(s)
    out["material"] = {"name": s.material.name, "k_weft": s.material.k_weft,
                       "k_warp": s.material.k_warp, "k_diag": s.material.k_diag}
    out["spacing_warp"] = s.spacing_warp if s.spacing_warp is not None else s.spacing
    out["seed"] = list(s.seed)
    out["yarns"] = [{"kind": y.kind, "index": y.index, "plane": list(y.plane), "k": y.k} for y in s.yarns]
    return out


def result_to_dict(result: FlattenResult, surface_source: str | None = None) -> dict:
    """The result file's content (see README, "Result file")."""
    mesh, xyz = result.mesh, result.xyz
    length = spring_lengths(xyz, mesh)
    return {
        "format": "flatweave-result",
        "version": 1,
        "flatweave": core.__version__,
        "surface": surface_source,
        "settings": _settings_dict(result.settings),
        "metrics": result.metrics,
        "drape": result.drape_stats,
        "nodes": {
            "ij": mesh.ij.tolist(),
            "uv": result.uv.tolist(),
            "xyz": xyz.tolist(),
        },
        "springs": {
            "ends": mesh.ends.tolist(),
            "kind": [KIND_NAMES[k] for k in mesh.kind.tolist()],
            "rest": mesh.rest.tolist(),
            "length": length.tolist(),
            "strain": (length / mesh.rest - 1.0).tolist(),
        },
        "cells": {
            "corners": mesh.cells.tolist(),
            "shear_deg": cell_shear_deg(xyz, mesh).tolist(),
        },
    }
