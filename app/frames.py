"""What the views draw, computed away from them (no Qt, no VTK).

A :class:`Frame` is one state of a piece: the mesh, its nodes on the surface
and in the pattern, the strain of every spring, the shear of every cell, the
boundary and dart nodes, and (when known) the pattern's outline. The solve
worker makes one per solver snapshot in its own thread, so the GUI thread
only copies arrays into the views; a finished result is turned into a frame by
the same :class:`FrameMaker`, so a live frame and the final one are drawn alike.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from flatweave.method.darts import DartSet
from flatweave.method.lattice import DIAG, SpringMesh
from flatweave.method.fibres import cell_fibres, reference_direction
from flatweave.method.metrics import area_beyond_lock_pct, cell_areas, cell_shear_deg, spring_strain
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.method.pattern import Pattern, make_pattern
from flatweave.method.result import FlattenResult
from flatweave.method.settings import FlattenSettings
from flatweave.geometry.quadrature import boundary_length, region_area
from flatweave.geometry.region import cover_for

__all__ = ["Frame", "FrameMaker"]

_EMPTY = np.zeros(0, dtype=np.int64)
_TOPOLOGIES = itertools.count(1)  # ids unique across runs, so a view never mistakes two meshes


@dataclass(frozen=True)
class Frame:
    """One drawable state.

    topology : an id that changes whenever the mesh (nodes, springs, cells) does
    mesh : SpringMesh; uv (n, 2); xyz (n, 3) on the surface; xy (n, 2) in the pattern
    strain : (m,) spring strain (l - r) / r; shear : (c,) signed cell shear, degrees
    boundary : node indices of boundary nodes
    dart_positive, dart_negative : node indices along the darts, by side
    dart_curves : the darts' curves on the surface, each (k, 3)
    pattern : the pattern (outline, darts' legs) or None when not computed yet;
        during a solve it may be a few iterations old
    iteration, energy, seconds : solver progress
    stats : nodes, springs, max thread strain %, max shear, and the pattern's
        boundary and area errors % when a pattern is known
    final : this is a finished result (not a live snapshot)
    draping (property) : a frame of the drape (the mesh being laid; no energy yet)
    status : the solver's message (final frames)
    fibre : (c,) the weft's signed deviation from the rosette per cell, degrees
        (:mod:`flatweave.method.fibres`; NaN where the rosette does not reach)
    result : the finished result the frame shows (:meth:`FrameMaker.from_result`), else None:
        the metrics panel judges it, not the document's, when it is a preview
    """

    topology: int
    mesh: SpringMesh
    uv: np.ndarray
    xyz: np.ndarray
    xy: np.ndarray
    strain: np.ndarray
    shear: np.ndarray
    boundary: np.ndarray
    dart_positive: np.ndarray
    dart_negative: np.ndarray
    dart_curves: tuple
    pattern: Pattern | None
    iteration: int
    energy: float
    seconds: float
    stats: dict = field(default_factory=dict)
    final: bool = False
    status: str = ""
    fibre: np.ndarray = field(default_factory=lambda: np.zeros(0))
    result: FlattenResult | None = None

    @property
    def draping(self) -> bool:
        return not self.final and math.isnan(self.energy)


class FrameMaker:
    """Makes frames for one surface and one set of settings, caching what
    depends only on the mesh's topology (boundary, dart nodes) or only on the
    surface (the darts' curves, boundary length and area)."""

    def __init__(self, surface: NurbsSurface, settings: FlattenSettings,
                 boundary_length_3d: float | None = None, area_3d: float | None = None):
        self.surface = surface
        self.settings = settings
        self.darts = DartSet(surface, settings.darts)
        self._L3 = boundary_length_3d
        self._A3 = area_3d
        self._curves = None
        self._mesh = None
        self._topology = 0
        self._boundary = _EMPTY
        self._xy = np.zeros((0, 2))
        self._dart_nodes = (_EMPTY, _EMPTY)
        self._rosette = None

    # ------------------------------------------------------------------ cached
    @property
    def L3(self) -> float:
        if self._L3 is None:  # a trimmed piece's: its loops' length
            region = self.settings.region
            self._L3 = float(boundary_length(self.surface) if region is None else
                             cover_for(self.surface, region).boundary_length)
        return self._L3

    @property
    def A3(self) -> float:
        if self._A3 is None:  # a trimmed piece's: its region's area
            region = self.settings.region
            self._A3 = float(region_area(self.surface) if region is None else cover_for(self.surface, region).area)
        return self._A3

    @property
    def total_curvature(self) -> float:
        """The piece's integrated Gaussian curvature (cached by its :class:`flatweave.geometry.region.Cover`)."""
        return cover_for(self.surface, self.settings.region).total_curvature

    def dart_curves(self) -> tuple:
        if self._curves is None:
            self._curves = tuple(self.surface.points(d.curve_uv(self.surface)) for d in self.settings.darts)
        return self._curves

    def _topology_of(self, mesh: SpringMesh, uv: np.ndarray, xyz: np.ndarray) -> int:
        if mesh is not self._mesh:
            self._mesh = mesh
            self._topology = next(_TOPOLOGIES)
            self._boundary = np.flatnonzero(mesh.boundary_nodes())
            self._xy = mesh.lattice_xy()
            self._dart_nodes = self._find_dart_nodes(mesh, uv, xyz)
        return self._topology

    def _find_dart_nodes(self, mesh, uv, xyz) -> tuple[np.ndarray, np.ndarray]:
        """Nodes within a cell diagonal of each dart's curve, by side (core's rule,
        run on the candidates a k-d tree finds near the curve, to bound memory)."""
        if not len(self.darts) or mesh.n_nodes == 0:
            return _EMPTY, _EMPTY
        reach = float(np.hypot(mesh.r_weft, mesh.r_warp))
        tree = cKDTree(xyz)
        pos, neg = [], []
        for dart, curve in zip(self.settings.darts, self.dart_curves()):
            if len(curve) < 2:
                continue
            step = float(np.linalg.norm(np.diff(curve, axis=0), axis=1).max())
            near = tree.query_ball_point(curve, reach + step / 2 + 1e-12)
            cand = np.unique(np.concatenate([np.asarray(c, dtype=np.int64) for c in near]))
            if not len(cand):
                continue
            (lab,) = DartSet(self.surface, (dart,)).dart_nodes([curve], uv[cand], xyz[cand], reach)
            pos.append(cand[lab["positive"]])
            neg.append(cand[lab["negative"]])
        join = lambda parts: np.unique(np.concatenate(parts)).astype(np.int64) if parts else _EMPTY  # noqa: E731
        return join(pos), join(neg)

    # ------------------------------------------------------------------ frames
    def pattern(self, mesh: SpringMesh, uv: np.ndarray, xyz: np.ndarray) -> Pattern:
        """The pattern of a state, as the pipeline makes it."""
        return make_pattern(self.surface, mesh, xyz, darts=self.darts if len(self.darts) else None, uv=uv)

    def frame(self, mesh: SpringMesh, uv: np.ndarray, xyz: np.ndarray, iteration: int, energy: float,
              seconds: float, strain: np.ndarray | None = None, pattern: Pattern | None = None,
              final: bool = False, status: str = "", result: FlattenResult | None = None) -> Frame:
        topology = self._topology_of(mesh, uv, xyz)
        if strain is None:
            strain = spring_strain(xyz, mesh)
        shear = cell_shear_deg(xyz, mesh)
        thread = mesh.kind != DIAG
        stats = {"nodes": mesh.n_nodes, "springs": mesh.n_springs,
                 "max_thread_strain_pct": float(100 * np.abs(strain[thread]).max(initial=0.0)),
                 "max_shear_deg": float(np.abs(shear).max(initial=0.0)),
                 "area_beyond_lock_pct": area_beyond_lock_pct(shear, cell_areas(xyz, mesh), mesh.material.lock_deg)}
        if pattern is not None:
            stats.update(self.pattern_stats(pattern))
        stats["total_curvature"] = self.total_curvature  # the outline errors' limits scale with it
        pos, neg = self._dart_nodes
        if self._rosette is None:
            self._rosette = reference_direction(self.surface, self.settings)
        fibre = cell_fibres(xyz, uv, mesh, self._rosette, shear_deg=shear).deviation_deg
        return Frame(topology, mesh, uv, xyz, self._xy, strain, shear, self._boundary, pos, neg,
                     self.dart_curves(), pattern, int(iteration), float(energy), float(seconds), stats,
                     final, status, fibre, result)

    def pattern_stats(self, pattern: Pattern) -> dict:
        """The pattern's boundary and area errors, % (a frame's stats)."""
        return {"boundary_error_pct": 100 * abs(pattern.perimeter - self.L3) / self.L3,
                "area_error_pct": 100 * abs(pattern.area - self.A3) / self.A3}

    def from_snapshot(self, snap, pattern: Pattern | None = None) -> Frame:
        """A live frame from a :class:`flatweave.method.solver.Snapshot`."""
        return self.frame(snap.mesh, snap.uv, snap.xyz, snap.iteration, snap.energy, snap.seconds,
                          strain=snap.strain, pattern=pattern)

    def from_result(self, result: FlattenResult) -> Frame:
        """The frame of a finished result (its own pattern and metrics)."""
        m = result.metrics
        frame = self.frame(result.mesh, result.uv, result.xyz, m.get("iterations", 0),
                           m.get("energy", math.nan), m.get("seconds", 0.0), pattern=result.pattern,
                           final=True, status=result.status or str(m.get("solver_status", "")), result=result)
        # the result's own metrics are the reference (computed once, by the pipeline)
        for key in ("boundary_error_pct", "area_error_pct", "max_thread_strain_pct", "max_shear_deg",
                    "area_beyond_lock_pct", "uncovered_pct", "total_curvature", "fit_max_deviation_pct"):
            if key in m:
                frame.stats[key] = float(m[key])
        return frame
