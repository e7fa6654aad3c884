"""The initial drape of the spring mesh on the surface (paper section 3.1).

Every node is placed exactly on the surface, in three steps:

1. **Constrained paths.** From the seed point two paths of equidistant nodes
   run along the weft and warp directions, each node found by One-Neighbour
   mapping: the intersection of a sphere of radius r around the previous node,
   a plane and the surface (Newton in (u, v)). The planes are the paper's
   normal sections through the seed (``paths="plane"``) or, with
   ``paths="geodesic"``, planes through each new node containing its normal
   and the previous chord (geodesic threads).
2. **Two-Neighbour mapping.** A node whose warp neighbour A, weft neighbour B
   and their common diagonal neighbour C exist is placed at distance r_warp
   from A and r_weft from B (two spheres and the surface), on the far side
   from C. Nodes of one anti-diagonal front need only the previous front, so
   a band of fronts is solved at once by one coupled, vectorised Newton
   iteration (forward substitution front by front) and checked once: the
   paper's quadrant-by-quadrant sweep, all four quadrants together, with the
   front-by-front sweep's result.
3. **Node Filling.** Where the sweep stops short of the region (it cannot
   turn corners of a region far from rectangular), a boundary node extends
   its thread by One-Neighbour mapping (plane through the node containing its
   normal and the thread's last chord); Two-Neighbour mapping then fills on
   from the new node. One new seed per connected gap per round keeps the
   weft and warp springs at rest length except where the mesh closes a loop.
   Repeated until no node is added.

A position whose node would leave the domain, fold back over the mesh or land
within half a spacing of an existing node stays empty for good.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from flatweave.errors import SettingsError, SolverError
from flatweave.geometry.numerics import nonfinite_rows, solve2
from flatweave.method.lattice import DIAG, Material, SpringMesh, build_mesh
from flatweave.geometry.nurbs import NurbsSurface

__all__ = ["DrapeSettings", "DrapeResult", "drape", "refill", "estimate_node_count", "check_node_count",
           "available_memory", "node_limit", "BYTES_PER_NODE"]

_NEWTON_MAXIT = 40

BYTES_PER_NODE = 12_000
"""Memory a flattening takes per mesh node, in bytes, for refusing meshes the
machine cannot hold (:func:`node_limit`): the measured peak with a margin for
the factorisation's n log n fill (docs/decisions/0007-refuse-unusable-surfaces-and-sizes.md)."""

REPORT_SHARE = 9.0
"""After a progress report the drape waits at least this many times the report's
own length before the next, so reports (a large mesh, a slow viewer) take at
most a tenth of a drape."""


@dataclass(frozen=True)
class DrapeSettings:
    """How the mesh is laid onto the surface.

    spacing_weft, spacing_warp : rest lengths r_weft (along rows) and r_warp (along columns)
    seed : (s, t) fractions of the parameter domain; (0.5, 0.5) is its centre
    angle_deg : weft direction in the tangent plane at the seed, measured from
        S_u towards S_v (degrees)
    paths : "plane" (the paper's normal sections) or "geodesic"
    max_nodes : refuse (up front) meshes estimated larger than this, or larger
        than the available memory holds (:func:`node_limit`)
    """

    spacing_weft: float
    spacing_warp: float | None = None
    seed: tuple[float, float] = (0.5, 0.5)
    angle_deg: float = 0.0
    paths: str = "plane"
    max_nodes: int = 2_000_000

    @property
    def r_weft(self) -> float:
        return float(self.spacing_weft)

    @property
    def r_warp(self) -> float:
        return float(self.spacing_warp if self.spacing_warp is not None else self.spacing_weft)


@dataclass(frozen=True)
class DrapeResult:
    """The draped mesh.

    mesh : SpringMesh (topology; node order sorted by lattice row, then column)
    uv : (n, 2) float, parameters of every node (inside the domain)
    xyz : (n, 3) float, the nodes on the surface
    stats : dict, counts of nodes by how they were placed, loop-closing springs,
        seconds
    """

    mesh: SpringMesh
    uv: np.ndarray
    xyz: np.ndarray
    stats: dict = field(default_factory=dict)


def estimate_node_count(area: float, r_weft: float, r_warp: float) -> int:
    """Nodes a mesh of the given spacings needs to cover ``area``."""
    return int(np.ceil(area / (r_weft * r_warp)))


def available_memory() -> int | None:
    """Bytes of memory available to a new computation: ``MemAvailable`` of
    /proc/meminfo (Linux), else the free physical pages (``os.sysconf``), else
    None (unknown: only ``max_nodes`` limits the mesh)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024  # the file's unit is kB
    except (OSError, ValueError, IndexError):
        pass
    try:
        pages, size = os.sysconf("SC_AVPHYS_PAGES"), os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):
        return None
    return pages * size if pages > 0 and size > 0 else None


def node_limit(max_nodes: int) -> tuple[int, int | None]:
    """(the largest mesh allowed, the available memory in bytes or None): the
    smaller of ``max_nodes`` and the nodes that fit in the available memory at
    :data:`BYTES_PER_NODE` each."""
    memory = available_memory()
    if memory is None:
        return int(max_nodes), None
    return int(min(max_nodes, memory // BYTES_PER_NODE)), memory


def _bytes(n: float) -> str:
    """``n`` bytes for people: '1.9 TB', '640 MB'."""
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n / 1e3:.3g} kB"


# ---------------------------------------------------------------- Newton kernels
def _newton(surface: NurbsSurface, uv0: np.ndarray, residual, tol: np.ndarray):
    """Vectorised Newton for k independent 2x2 systems on the surface.

    residual(S, Su, Sv, idx) -> (F (k', 2), J (k', 2, 2)) for the rows idx.
    Returns (uv (k, 2), converged (k,), S, Su, Sv (k, 3) each): the surface at
    the converged rows' uv (the evaluation that found them converged, so the
    caller need not evaluate them again; other rows hold zeros). Iterates may
    step outside the domain by up to half its size (the surface is extended
    polynomially there).
    """
    dom = surface.domain
    size = dom[:, 1] - dom[:, 0]
    lo, hi = dom[:, 0] - 0.5 * size, dom[:, 1] + 0.5 * size
    uv = np.array(uv0, dtype=float)
    k = uv.shape[0]
    # residuals are lengths: they cannot fall below the rounding of the coordinates
    tol = np.maximum(tol, 16 * np.finfo(float).eps * float(np.abs(surface.ctrlpts).max()))
    conv = np.zeros(k, dtype=bool)
    out = np.zeros((3, k, 3))
    active = np.arange(k)
    max_step = 0.25 * size
    for _ in range(_NEWTON_MAXIT):
        if active.size == 0:
            break
        S, Su, Sv = surface.derivatives(uv[active])
        F, J = residual(S, Su, Sv, active)
        finite = np.isfinite(F).all(axis=1) & np.isfinite(J).reshape(-1, 4).all(axis=1)
        done = finite & (np.abs(F).max(axis=1) <= tol[active])
        if done.all():  # the usual last round: no step to take (a front's Newton ends here)
            conv[active] = True
            out[0][active], out[1][active], out[2][active] = S, Su, Sv
            break
        if done.any():
            conv[active[done]] = True
            for o, a in zip(out, (S, Su, Sv)):
                o[active[done]] = a[done]
        go = finite & ~done
        if go.all():  # no copies of the whole batch when every row goes on
            step, ok = solve2(J, F)
            idx = active
        else:
            step, ok = solve2(J[go], F[go])
            idx = active[go]
        if not ok.all():
            idx, step = idx[ok], step[ok]
        factor = np.min(max_step / np.maximum(np.abs(step), 1e-300), axis=1, initial=1.0)
        uv[idx] += step * np.minimum(1.0, factor)[:, None]
        inside = np.all((uv[idx] >= lo) & (uv[idx] <= hi), axis=1)
        active = idx[inside]
    return uv, conv, out[0], out[1], out[2]


def _one_neighbour(surface, P0, radius, normal, uv_guess):
    """One-Neighbour mapping: |S - P0| = r, normal . (S - P0) = 0, S on the surface."""
    N = normal / np.linalg.norm(normal, axis=1, keepdims=True)

    def residual(S, Su, Sv, idx):
        d = S - P0[idx]
        r = radius[idx][:, None]
        F = np.column_stack([(np.einsum("ij,ij->i", d, d) - r[:, 0] ** 2) / (2 * r[:, 0]),
                             np.einsum("ij,ij->i", N[idx], d)])
        J = np.empty((len(idx), 2, 2))
        J[:, 0, 0] = np.einsum("ij,ij->i", d, Su) / r[:, 0]
        J[:, 0, 1] = np.einsum("ij,ij->i", d, Sv) / r[:, 0]
        J[:, 1, 0] = np.einsum("ij,ij->i", N[idx], Su)
        J[:, 1, 1] = np.einsum("ij,ij->i", N[idx], Sv)
        return F, J

    return _newton(surface, uv_guess, residual, 1e-12 * radius)


def _two_neighbour(surface, A, ra, B, rb, uv_guess):
    """Two-Neighbour mapping: |S - A| = ra, |S - B| = rb, S on the surface."""

    centres = np.stack([A, B], axis=1)  # (k, 2, 3)
    radii = np.column_stack([ra, rb])

    def residual(S, Su, Sv, idx):
        # both spheres at once: a front's Newton is a few hundred of these calls, each a few rows
        d = S[:, None, :] - centres[idx]  # (k', 2, 3)
        r = radii[idx]
        F = (np.einsum("kic,kic->ki", d, d) - r ** 2) / (2 * r)
        J = np.einsum("kic,kjc->kij", d, np.stack([Su, Sv], axis=1)) / r[:, :, None]
        return F, J

    return _newton(surface, uv_guess, residual, 1e-12 * np.minimum(ra, rb))


def _tangent_uv(Su: np.ndarray, Sv: np.ndarray, vec: np.ndarray) -> np.ndarray:
    """(k, 2) parameter steps whose image under [Su Sv] best matches vec (least squares)."""
    G = np.stack([np.stack([np.einsum("ij,ij->i", Su, Su), np.einsum("ij,ij->i", Su, Sv)], -1),
                  np.stack([np.einsum("ij,ij->i", Su, Sv), np.einsum("ij,ij->i", Sv, Sv)], -1)], 1)
    rhs = np.column_stack([np.einsum("ij,ij->i", Su, vec), np.einsum("ij,ij->i", Sv, vec)])
    G = G + 1e-12 * np.trace(G, axis1=1, axis2=2)[:, None, None] * np.eye(2)
    return np.linalg.solve(G, rhs[..., None])[..., 0]


# ---------------------------------------------------------------- the lattice
class _Lattice:
    """Which lattice position holds which node, on a grid that grows as needed."""

    MARGIN = 3

    def __init__(self):
        h = 16
        self.grid = np.full((2 * h + 1, 2 * h + 1), -1, dtype=np.int64)
        self.dead = np.zeros_like(self.grid, dtype=bool)
        self.off = np.array([h, h])

    def ensure(self, ij: np.ndarray) -> None:
        """Grow the grid so positions ij keep MARGIN empty cells to the border."""
        if ij.size == 0:
            return
        g = ij + self.off
        R, C = self.grid.shape
        need_lo = np.maximum(self.MARGIN - g.min(axis=0), 0)
        need_hi = np.maximum(g.max(axis=0) + self.MARGIN + 1 - np.array([R, C]), 0)
        if np.any(need_lo) or np.any(need_hi):
            pad_lo = np.where(need_lo > 0, np.maximum(need_lo, np.array([R, C]) // 2), 0)
            pad_hi = np.where(need_hi > 0, np.maximum(need_hi, np.array([R, C]) // 2), 0)
            pad = ((pad_lo[0], pad_hi[0]), (pad_lo[1], pad_hi[1]))
            self.grid = np.pad(self.grid, pad, constant_values=-1)
            self.dead = np.pad(self.dead, pad, constant_values=False)
            self.off = self.off + pad_lo

    def set(self, ij: np.ndarray, nodes: np.ndarray) -> None:
        self.ensure(ij)
        g = ij + self.off
        self.grid[g[:, 0], g[:, 1]] = nodes

    def kill(self, ij: np.ndarray) -> None:
        g = ij + self.off
        self.dead[g[:, 0], g[:, 1]] = True

    def at(self, ij: np.ndarray) -> np.ndarray:
        """Node index at positions ij (-1 if empty); positions must be on the grid."""
        g = ij + self.off
        return self.grid[g[:, 0], g[:, 1]]

    def occupied(self) -> np.ndarray:
        return self.grid >= 0

    def free(self) -> np.ndarray:
        return (self.grid < 0) & ~self.dead

    def positions(self, mask: np.ndarray) -> np.ndarray:
        """(k, 2) lattice positions (i, j) where the grid-shaped mask is true."""
        return np.argwhere(mask) - self.off


def _shift(a: np.ndarray, di: int, dj: int, fill=False) -> np.ndarray:
    """out[i, j] = a[i + di, j + dj] (fill outside)."""
    out = np.full_like(a, fill)
    R, C = a.shape
    out[max(0, -di):R - max(0, di), max(0, -dj):C - max(0, dj)] = \
        a[max(0, di):R - max(0, -di), max(0, dj):C - max(0, -dj)]
    return out


# ---------------------------------------------------------------- the drape
_CONFIGS = np.array([[1, 1], [1, -1], [-1, 1], [-1, -1]])
"""Two-Neighbour configurations (a, b): A = (i-a, j), B = (i, j-b), C = (i-a, j-b)."""
_EIGHT = np.array([[di, dj] for di in (-1, 0, 1) for dj in (-1, 0, 1) if di or dj])
_BEHIND = [(a, 0) for a in (1, -1)] + [(0, b) for b in (1, -1)] + [(a, b) for a in (1, -1) for b in (1, -1)]
"""Offsets d of the neighbours p - d a configuration needs occupied."""
_CONFIG_NEIGHBOURS = [(_BEHIND.index((a, 0)), _BEHIND.index((0, b)), _BEHIND.index((a, b))) for a, b in _CONFIGS]
"""For each of ``_CONFIGS``: the indices into ``_BEHIND`` of its A, B and C."""
_BEHIND = np.array(_BEHIND)

_BAND_START = 2
"""Fronts in the first band of a Two-Neighbour fill from the whole lattice (:meth:`_Builder.two_neighbour_fill`)."""
_BAND_MIN = 4
"""The fewest fronts a band speculates on after one was cut short."""
_BAND_MAX = 32
"""The most fronts in one band."""
_BAND_ITERATIONS = 4
"""Newton iterations a node of a band's later front gets once its A and B are done: a node not
done by then ends the band before its front (the next band solves it with A and B fixed, with all of
Newton's iterations)."""


def _choose_configs(pos: np.ndarray, V: np.ndarray) -> np.ndarray:
    """(k, 2) the configuration of each position: of those serving it (V), the
    one whose C is nearest the seed in lattice steps (the first of a tie)."""
    C = pos[:, None, :] - _CONFIGS[None, :, :]
    score = np.where(V, np.abs(C).sum(axis=2), np.iinfo(np.int64).max)
    return _CONFIGS[np.argmin(score, axis=1)]


class _Marks:
    """Positions of the lattice taken or killed for a while (a band's guess of
    the fronts, or the fronts it keeps so far), undone on leaving the
    ``with`` block: the band's positions are free before it."""

    def __init__(self, lat: _Lattice):
        self.lat = lat
        self.cells = []

    def take(self, ij: np.ndarray, rows: np.ndarray) -> None:
        g = ij + self.lat.off
        self.lat.grid[g[:, 0], g[:, 1]] = rows
        self.cells.append(g)

    def kill(self, ij: np.ndarray) -> None:
        g = ij + self.lat.off
        self.lat.dead[g[:, 0], g[:, 1]] = True
        self.cells.append(g)

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        if self.cells:
            g = np.concatenate(self.cells)
            self.lat.grid[g[:, 0], g[:, 1]] = -1
            self.lat.dead[g[:, 0], g[:, 1]] = False


class _Refs:
    """A band's references to one neighbour (A, B or C) of each of its nodes:
    a mesh node (row below n) or a node of the band (n + its band row)."""

    def __init__(self, rows: np.ndarray, n: int, uv: np.ndarray, xyz: np.ndarray):
        self.dep = rows >= n
        self.j = np.where(self.dep, rows - n, 0)
        mesh = np.where(self.dep, 0, rows)
        self.mesh = {"uv": uv[mesh], "xyz": xyz[mesh]}

    def pick(self, band: np.ndarray, sl: slice, kind: str) -> np.ndarray:
        """The neighbour's values for the band rows ``sl``: from ``band`` (the
        band's values, by band row) or the mesh's ``kind`` ("uv" or "xyz")."""
        return np.where(self.dep[sl, None], band[self.j[sl]], self.mesh[kind][sl])


class _Builder:
    """Mutable state of one drape: nodes so far and the lattice."""

    def __init__(self, surface: NurbsSurface, settings: DrapeSettings):
        self.surface = surface
        self.s = settings
        self.lat = _Lattice()
        self.uv = np.zeros((0, 2))
        self.xyz = np.zeros((0, 3))
        self.ij = np.zeros((0, 2), dtype=np.int64)
        self.normal = np.zeros((0, 3))
        self.how = np.zeros(0, dtype=np.int8)  # 0 seed, 1 path, 2 two-neighbour, 3 filling
        self._cap, self._buf = 0, {}
        self.trees = {}  # tier name -> (first node, end, k-d tree); see _far_from_trees
        self.separated = None  # callable(uv_a, uv_b, xyz_a, xyz_b) -> bool: a dart lies between
        self.on_add = None  # callable() after every batch of new nodes (progress reports)
        self.inside = None  # callable(uv) -> (k,) bool: in the piece's region (a trimmed face), else the domain
        self.rmin = min(settings.r_weft, settings.r_warp)
        dom = surface.domain
        self.dom = dom
        self.tol_uv = 1e-10 * (dom[:, 1] - dom[:, 0])

    # -- bookkeeping
    def add(self, ij, uv, how, xyz=None, su=None, sv=None) -> None:
        """Append nodes at lattice positions ij (k, 2) and parameters uv (k, 2);
        xyz, su, sv (k, 3), if given, are the surface and its derivatives there
        (from the Newton iteration that placed them: not evaluated again)."""
        if xyz is None:
            ev = self.surface.evaluate(uv)
            xyz, normal = ev.xyz, ev.normal
        else:
            normal = self.surface.normals(uv, su, sv)
        bad = nonfinite_rows(xyz) | nonfinite_rows(normal)
        if bad.any():  # a NaN in the k-d trees would fail obscurely later
            n = int(bad.sum())
            raise SolverError(f"the surface evaluation returned a non-finite point or normal at {n:,} "
                              f"node{'s' if n != 1 else ''} while draping; the solve stopped and nothing was changed")
        n0 = self.uv.shape[0]
        n1 = n0 + len(uv)
        # the node arrays are views of buffers that grow geometrically: a front appends in O(front), not
        # O(nodes) (the drape adds hundreds of fronts)
        names = ("uv", "xyz", "normal", "ij", "how")
        if n1 > self._cap:
            self._cap = max(2 * self._cap, n1, 64)
            for name in names:
                old = getattr(self, name)
                buf = np.empty((self._cap,) + old.shape[1:], dtype=old.dtype)
                buf[:n0] = old
                self._buf[name] = buf
        for name, new in zip(names, (uv, xyz, normal, ij, how)):
            buf = self._buf[name]
            buf[n0:n1] = new
            setattr(self, name, buf[:n1])
        self.lat.set(ij, np.arange(n0, n1))
        if self.on_add is not None:
            self.on_add()

    def accept_uv(self, uv: np.ndarray, conv: np.ndarray, S: np.ndarray, Su: np.ndarray,
                  Sv: np.ndarray) -> tuple[np.ndarray, ...]:
        """Converged and inside the domain (to round-off); returns (ok, clipped uv,
        S, Su, Sv): the surface at the clipped uv of the converged rows (S, Su, Sv
        from :func:`_newton`, evaluated again only where the clip moved a node)."""
        inside = np.all((uv >= self.dom[:, 0] - self.tol_uv) & (uv <= self.dom[:, 1] + self.tol_uv), axis=1)
        clipped = np.clip(uv, self.dom[:, 0], self.dom[:, 1])
        ok = conv & inside
        moved = np.flatnonzero(ok & np.any(clipped != uv, axis=1))
        if moved.size:
            S, Su, Sv = S.copy(), Su.copy(), Sv.copy()
            S[moved], Su[moved], Sv[moved] = self.surface.derivatives(clipped[moved])
        if self.inside is not None and ok.any():
            ok[ok] = self.inside(clipped[ok])
        return ok, clipped, S, Su, Sv

    def _tree(self, lo: int, hi: int):
        # unbalanced and not compacted: built in half the time, the same answers
        return lo, hi, cKDTree(self.xyz[lo:hi], balanced_tree=False, compact_nodes=False)

    def far_from_mesh(self, P: np.ndarray) -> np.ndarray:
        """(k,) bool: points at least half a spacing from every node and from each
        other (of a close pair the first is kept)."""
        ok = self._far_from_trees(P)
        _, j = self._close_pairs(P, ok)
        ok[np.unique(j)] = False
        return ok

    # -- step 1: seed and constrained paths
    def seed_and_paths(self) -> None:
        s = self.s
        sd = np.asarray(s.seed, dtype=float)
        if sd.shape != (2,) or not np.all(np.isfinite(sd)) or np.any(sd < 0) or np.any(sd > 1):
            raise SettingsError(f"seed {tuple(s.seed)} must be two fractions of the domain in [0, 1]")
        uv0 = (self.dom[:, 0] + sd * (self.dom[:, 1] - self.dom[:, 0]))[None, :]
        ev = self.surface.evaluate(uv0)
        self.add(np.zeros((1, 2), dtype=np.int64), uv0, 0)
        n0 = ev.normal[0]
        su = ev.su[0]
        if np.linalg.norm(su) < 1e-300:
            su = ev.sv[0]
        e1 = su - np.dot(su, n0) * n0
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(n0, e1)
        a = np.radians(s.angle_deg)
        d_weft = np.cos(a) * e1 + np.sin(a) * e2
        d_warp = np.cross(n0, d_weft)
        self.d_weft, self.d_warp = d_weft, d_warp
        # four lanes: +weft, -weft, +warp, -warp
        steps = np.array([[0, 1], [0, -1], [1, 0], [-1, 0]])
        dirs = np.array([d_weft, -d_weft, d_warp, -d_warp])
        radius = np.array([s.r_weft, s.r_weft, s.r_warp, s.r_warp])
        fixed_normal = np.cross(n0[None, :], dirs)  # planes through the seed
        P = np.repeat(ev.xyz, 4, axis=0)
        prev = P - dirs * radius[:, None]
        uv_cur = np.repeat(uv0, 4, axis=0)
        guess = uv_cur + _tangent_uv(np.repeat(ev.su, 4, 0), np.repeat(ev.sv, 4, 0),
                                     dirs * radius[:, None])
        nrm = np.repeat(ev.normal, 4, axis=0)
        pos = np.zeros((4, 2), dtype=np.int64)
        alive = np.ones(4, dtype=bool)
        limit = 4 * s.max_nodes
        for _ in range(limit):
            if not alive.any():
                break
            lanes = np.flatnonzero(alive)
            if s.paths == "geodesic":
                chord = P[lanes] - prev[lanes]
                normal = np.cross(nrm[lanes], chord / np.linalg.norm(chord, axis=1, keepdims=True))
            else:
                normal = fixed_normal[lanes]
            ok, uv_new, xyz_new, su_new, sv_new = self.accept_uv(
                *_one_neighbour(self.surface, P[lanes], radius[lanes], normal, guess[lanes]))
            ok &= np.einsum("ij,ij->i", xyz_new - P[lanes], P[lanes] - prev[lanes]) > 0
            ok[ok] = self.far_from_mesh(xyz_new[ok])
            alive[lanes[~ok]] = False
            good = lanes[ok]
            if good.size == 0:
                break
            pos[good] += steps[good]
            uv_old = uv_cur[good].copy()
            uv_cur[good] = uv_new[ok]
            guess[good] = 2 * uv_new[ok] - uv_old
            prev[good] = P[good]
            P[good] = xyz_new[ok]
            self.add(pos[good].copy(), uv_new[ok], 1, xyz_new[ok], su_new[ok], sv_new[ok])
            nrm[good] = self.normal[-len(good):]

    # -- step 2: two-neighbour fronts
    def _valid_everywhere(self) -> tuple[np.ndarray, np.ndarray]:
        """Every position Two-Neighbour mapping can fill now: (pos (k, 2) in
        row-major order, V (k, 4) bool: which of ``_CONFIGS`` serve it)."""
        occ = self.lat.occupied()
        free = self.lat.free()
        # A = (i-a, j), B = (i, j-b), C = (i-a, j-b)
        valid = [free & _shift(occ, -a, 0) & _shift(occ, 0, -b) & _shift(occ, -a, -b) for a, b in _CONFIGS]
        pos = self.lat.positions(np.logical_or.reduce(valid))
        g = pos + self.lat.off
        return pos, np.stack([v[g[:, 0], g[:, 1]] for v in valid], axis=1).reshape(-1, 4)

    def _valid_near(self, new: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The same as :meth:`_valid_everywhere` after a front that placed nodes
        at ``new`` (k, 2) and tried every position valid before it: a position
        can only have become valid through one of its eight neighbours, so only
        those are looked at (O(front), not O(lattice), per front)."""
        lat = self.lat
        g = (new[:, None, :] + _EIGHT[None, :, :]).reshape(-1, 2) + lat.off
        width = lat.grid.shape[1]
        key = np.unique(g[:, 0] * width + g[:, 1])  # row-major, as np.argwhere
        key = key[(lat.grid.ravel()[key] < 0) & ~lat.dead.ravel()[key]]
        cand = np.column_stack([key // width, key % width]) - lat.off
        occ = [lat.at(cand - d) >= 0 for d in _BEHIND]  # (i-1, j), (i+1, j), (i, j-1), (i, j+1), 4 diagonals
        V = np.stack([occ[ia] & occ[ib] & occ[ic] for ia, ib, ic in _CONFIG_NEIGHBOURS], axis=1)
        keep = V.any(axis=1)
        return cand[keep], V[keep]

    def two_neighbour_fill(self, start: np.ndarray | None = None) -> int:
        """Fill every position reachable by Two-Neighbour mapping; returns nodes added.

        start : (k, 2) positions of the only nodes placed since the last fill
        (the filling seeds), or None to look at the whole lattice.

        The fronts go in bands: a band is the next few fronts as they would be
        if every node were accepted (:meth:`_speculate`), solved by one
        coupled Newton iteration (:meth:`_band_newton`) and checked at once
        (:meth:`_band`); then taken front by front as the sweep would take
        them (:meth:`_sweep_band`), up to the first front that is not the
        speculated one. Each front is what the front-by-front sweep makes of
        it, to round-off, at a fraction of the calls (a front of a few nodes
        costs the calls of a large one).
        """
        added = 0
        pos, V = self._valid_everywhere() if start is None else self._valid_near(start)
        # a scan of the whole lattice (a drape's first fill, a refill's) starts with a short band: a refill's
        # first front is scattered over the lattice and often all rejected; Node Filling goes on from the
        # last fill's band size
        m = getattr(self, "_band_m", _BAND_START) if start is not None else _BAND_START
        while len(pos):
            new, fronts, whole = self._band(pos, V, m)
            added += len(new)
            if len(new) == 0:
                return added
            pos, V = self._valid_near(new)
            # more fronts at once while bands are kept whole; fewer after a cut
            m = min(2 * m, _BAND_MAX) if whole else max(_BAND_MIN, fronts)
            self._band_m = m
        return added

    def _speculate(self, pos: np.ndarray, V: np.ndarray, m: int):
        """The next ``m`` fronts (fewer if they end) as they are if every node
        is accepted but those guessed well outside the domain: (positions
        (b, 2) front after front, the rows of their A, B and C (b,) each:
        nodes below ``len(self.uv)`` are the mesh's, the others the band's
        own, ``len(self.uv) + row``, their guesses (b, 2), whether each is
        guessed outside (b,), and the fronts' starts (fronts + 1,)). Each front is :meth:`_valid_near`'s after the
        last, the lattice marked meanwhile with the band's positions taken
        (or, guessed outside, dead: the fronts are not grown from nodes that
        will not be there; a wrong guess of it only ends the band where the
        sweep differs)."""
        lat = self.lat
        # a front is within one position of the last: the lattice is grown once for the whole band
        lat.ensure(np.array([pos.min(axis=0) - m - 1, pos.max(axis=0) + m + 1]))
        n = len(self.uv)
        lo, hi = self.dom[:, 0], self.dom[:, 1]
        parts, bounds, guesses, outs = [], [0], [], []
        flat, width = lat.grid.ravel(), lat.grid.shape[1]
        uv = self.uv  # then the mesh's (u, v) and the band's guesses, by row
        with _Marks(lat) as marks:
            for f in range(m):
                cfg = _choose_configs(pos, V)
                g = (pos[:, 0] + lat.off[0]) * width + pos[:, 1] + lat.off[1]
                da, db = cfg[:, 0] * width, cfg[:, 1]
                ref = (flat[g - da], flat[g - db], flat[g - da - db])
                U = [uv[r] for r in ref]
                X = U[0] + U[1] - U[2]
                parts.append((pos, *ref))
                guesses.append(X)
                # outside the domain by more than half the guess's step from A: the node will not be there
                reach = 0.5 * np.abs(X - U[0]).max(axis=1, keepdims=True)
                out = np.any((X < lo - reach) | (X > hi + reach), axis=1)
                outs.append(out)
                marks.take(pos[~out], n + bounds[-1] + np.flatnonzero(~out))
                marks.kill(pos[out])
                bounds.append(bounds[-1] + len(pos))
                if f + 1 == m:
                    break
                uv = np.concatenate([uv, X])
                pos, V = self._valid_near(pos[~out])
                if len(pos) == 0:
                    break
        return (*(np.concatenate(x) for x in zip(*parts)), np.concatenate(guesses), np.concatenate(outs),
                np.array(bounds))

    def _band(self, pos: np.ndarray, V: np.ndarray, m: int) -> tuple[np.ndarray, int, bool]:
        """Speculate, solve, check and add up to ``m`` fronts starting with the
        front ``pos, V``; returns (the positions added in the band's last kept
        front, fronts kept, whether the band was kept whole).

        A rejection in a front changes the fronts after it only where a node
        hangs on the rejected one (its A, B or C, or theirs): the others are
        in the same front with the same configuration (a position's
        configurations can only be fewer, and the chosen one is still among
        them and still the first best). So after a rejection each front is
        found again from the lattice as it now is and kept if it is the
        speculated one less the nodes hanging on a rejection; the band ends
        at the first front where it is not (a position whose configuration
        changed)."""
        n = len(self.uv)
        P, iA, iB, iC, X, out, bounds = self._speculate(pos, V, m)
        nf = len(bounds) - 1
        rows = [_Refs(i, n, self.uv, self.xyz) for i in (iA, iB, iC)]
        A, B, C = rows
        X, conv, failed, S, Su, Sv = self._band_newton(X, A, B, bounds)
        L, nL = nf, bounds[nf]
        front = np.repeat(np.arange(L), np.diff(bounds))
        ok, Xc, S, Su, Sv = self.accept_uv(X, conv, S, Su, Sv)
        moved = ok & np.any(Xc != X, axis=1)
        every = slice(0, nL)
        PA, PB, PC = (r.pick(S, every, "xyz") for r in rows)
        par = PA + PB - PC
        # a later front's node is the front-by-front one when it converged to the root near A + B - C (the
        # other root of the two spheres and the surface is near C); one that is not ends the band before
        # its front, if the sweep reaches it
        suspect = (front > 0) & (failed | (conv & (np.linalg.norm(S - par, axis=1) >= 0.25 * self.rmin)))
        ok &= np.einsum("ij,ij->i", S - PC, PA + PB - 2 * PC) > 0
        ok &= np.linalg.norm(S - PC, axis=1) > 0.5 * self.rmin
        ok &= np.linalg.norm(S - par, axis=1) < 2.0 * max(self.s.r_weft, self.s.r_warp)
        if self.separated is not None and ok.any():  # never a spring across a dart
            w = np.flatnonzero(ok)
            uA, uB = A.pick(Xc, every, "uv")[w], B.pick(Xc, every, "uv")[w]
            ok[w] = ~self.separated(uA, Xc[w], PA[w], S[w]) & ~self.separated(uB, Xc[w], PB[w], S[w])
        ok[ok] = self._far_from_trees(S[ok])
        pi, pj = self._close_pairs(S, ok)
        # the fronts in turn, as the front-by-front sweep takes them
        status = np.zeros(nL, dtype=np.int8)  # 1 added, 2 rejected, 0 neither (hangs on a rejection)
        with _Marks(self.lat) as marks:
            last = self._sweep_band(P, front, bounds, rows, ok, out, moved, suspect, pi, pj, status, marks)
        keep = front <= last
        self.lat.kill(P[keep & (status == 2)])
        take = keep & (status == 1)
        if take.any():
            self.add(P[take], Xc[take], 2, S[take], Su[take], Sv[take])
        whole = last + 1 == nf and nf == m
        return P[take & (front == last)], last + 1, whole

    def _sweep_band(self, P, front, bounds, rows, ok, out, moved, suspect, pi, pj, status, marks) -> int:
        """Take a checked band's fronts in turn as the front-by-front sweep
        would: sets ``status`` (1 added, 2 rejected) and returns the last front
        kept. Up to the first front where a node is not as the speculation
        took it (accepted, or rejected if guessed outside), the fronts are the
        speculated ones; from there on the lattice is marked as the kept
        fronts leave it (``marks``) and each front is found again on it."""
        n = len(self.uv)
        nL = len(front)
        L = len(bounds) - 1
        slow = False
        last = L - 1
        for f in range(L):
            lo_row, hi_row = bounds[f], bounds[f + 1]
            if not slow:
                idx = np.arange(lo_row, hi_row)
            else:
                g = slice(lo_row, hi_row)
                held = np.ones(hi_row - lo_row, dtype=bool)
                for r in rows:
                    held &= ~r.dep[g] | (status[r.j[g]] == 1)
                idx = lo_row + np.flatnonzero(held)
                prev = P[(front == f - 1) & (status == 1)]
                found, _ = self._valid_near(prev)
                if found.shape != P[idx].shape or not np.array_equal(found, P[idx]):
                    last = f - 1
                    break
            if suspect[idx].any():
                last = f - 1
                break
            okf = ok[idx]
            if len(pi):
                into = front[pj] == f
                # near a node of an earlier front (in the mesh by now), or the second of a close pair in this front
                hit = into & (front[pi] < f) & (status[pi] == 1)
                okf[np.isin(idx, pj[hit])] = False
                surv = np.zeros(nL, dtype=bool)
                surv[idx[okf]] = True
                same = into & (front[pi] == f) & surv[pi] & surv[pj]
                okf[np.isin(idx, pj[same])] = False
            status[idx] = np.where(okf, 1, 2)
            if not okf.any() or moved[idx[okf]].any():
                last = f  # no node to go on from, or the next front hangs on a node the domain's clip moved
                break
            if not slow and np.any(okf == out[idx]):
                slow = True
                done = np.flatnonzero(status[:lo_row] == 1)
                marks.take(P[done], n + done)
                marks.kill(P[:lo_row][status[:lo_row] == 2])
            if slow:
                marks.take(P[idx[okf]], n + idx[okf])
                marks.kill(P[idx[~okf]])
        return last

    def _close_pairs(self, P: np.ndarray, ok: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The pairs (i, j), i < j, of rows still ``ok`` whose points are within
        half a spacing."""
        none = np.zeros(0, dtype=np.int64)
        idx = np.flatnonzero(ok)
        if len(idx) < 2:
            return none, none
        r = 0.5 * self.rmin
        if len(idx) <= 32:
            Q = P[idx]
            d2 = np.sum((Q[:, None, :] - Q[None, :, :]) ** 2, axis=2)
            i, j = np.nonzero(np.triu(d2 <= r * r, 1))
        else:
            pairs = cKDTree(P[idx]).query_pairs(r, output_type="ndarray")
            if len(pairs) == 0:
                return none, none
            i, j = np.minimum(pairs[:, 0], pairs[:, 1]), np.maximum(pairs[:, 0], pairs[:, 1])
        return idx[i], idx[j]

    def _band_newton(self, X: np.ndarray, A: "_Refs", B: "_Refs", bounds: np.ndarray):
        """Newton for a band's nodes at once: each at r_warp from its A and
        r_weft from its B (:func:`_two_neighbour`), A and B the mesh's or the
        band's own, unknowns too. The Jacobian is block lower triangular
        (a node depends on itself and on earlier fronts), so the step is
        forward substitution front after front: dx = -J^-1 (F + F_A dx_A +
        F_B dx_B). A node is done when its residual is within the tolerance
        and its A and B are done; it fails when not finite, its Jacobian
        singular, out of bounds, not done in its iterations, or its A or B
        failed. The first front's failures are the front-by-front ones: its
        Newton is :func:`_newton`'s, A and B fixed, step for step. Returns
        (X, converged, failed, S, Su, Sv)."""
        surface = self.surface
        ra, rb = self.s.r_warp, self.s.r_weft
        dom = surface.domain
        size = dom[:, 1] - dom[:, 0]
        lo, hi = dom[:, 0] - 0.5 * size, dom[:, 1] + 0.5 * size
        max_step = 0.25 * size
        tol = max(1e-12 * min(ra, rb), 16 * np.finfo(float).eps * float(np.abs(surface.ctrlpts).max()))
        b = len(X)
        X = X.copy()
        S, T = np.zeros((b, 3)), np.zeros((b, 2, 3))  # the points, (S_u, S_v)
        j2, dep2 = np.column_stack([A.j, B.j]), np.column_stack([A.dep, B.dep])
        mesh2 = np.stack([A.mesh["xyz"], B.mesh["xyz"]], axis=1)
        r2 = np.array([ra, rb])
        done = np.zeros(b, dtype=bool)
        failed = np.zeros(b, dtype=bool)
        stop = np.zeros(b, dtype=bool)  # failed, or done outside the domain
        # a node whose A and B (both the mesh's) are farther apart than its two spacings has no root: it fails
        # at once, as its Newton would after all its iterations (and the band's with it: a refill's first front
        # across an opened dart has several)
        apart = ~A.dep & ~B.dep
        apart[apart] = np.linalg.norm(A.mesh["xyz"][apart] - B.mesh["xyz"][apart], axis=1) > ra + rb + 4 * tol
        failed |= apart
        stop |= apart
        waited = np.zeros(b, dtype=np.int64)
        small_b, good_b = np.zeros(b, dtype=bool), np.zeros(b, dtype=bool)
        step0_b, inv_b, c_b = np.zeros((b, 2)), np.zeros((b, 2, 2)), np.zeros((b, 2, 2))
        dx = np.zeros((b, 2))
        L = len(bounds) - 1
        front = np.repeat(np.arange(L), np.diff(bounds))
        f0 = 0  # the fronts before f0 are done
        for it in range(_NEWTON_MAXIT + (L - 1) * (_BAND_ITERATIONS + 1)):
            lo_row, nL = bounds[f0], bounds[L]
            sl = slice(lo_row, nL)
            todo = ~(done[sl] | failed[sl])
            act = lo_row + np.flatnonzero(todo)
            if act.size == 0:
                break
            S[act], T[act, 0], T[act, 1] = surface.derivatives(X[act])
            ja, jb, da, db = A.j[sl], B.j[sl], A.dep[sl], B.dep[sl]
            # residuals, Jacobians and steps of the rows evaluated (the others' are not used), both spheres
            # at once as in _two_neighbour
            j2a, dep2a = j2[act], dep2[act]
            d = S[act][:, None, :] - np.where(dep2a[:, :, None], S[j2a], mesh2[act])  # (k, 2, 3)
            F = (np.einsum("kic,kic->ki", d, d) - r2 ** 2) / (2 * r2)
            Ta = T[act]
            J = np.empty((len(act), 2, 2))
            for i in range(2):  # four row products: einsum's "kic,kjc->kij" is slower by three
                for j in range(2):
                    J[:, i, j] = np.einsum("kc,kc->k", d[:, i], Ta[:, j])
            J /= r2[:, None]
            with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
                finite = np.isfinite(F).all(axis=1) & np.isfinite(J).reshape(-1, 4).all(axis=1)
                small_b[act] = finite & (np.abs(F).max(axis=1) <= tol)
                step0_b[act], solved = solve2(J, F)  # the step with A and B held
                good_b[act] = finite & solved
                # J^-1, for the steps of A and B: dx = step0 - J^-1 (F_A dx_A, F_B dx_B)
                det = np.where(solved, J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0], 1.0)
                inv_b[act] = np.stack([J[:, 1, 1], -J[:, 0, 1], -J[:, 1, 0], J[:, 0, 0]],
                                      axis=1).reshape(-1, 2, 2) / det[:, None, None]
                # how the residuals move with A's and B's steps (zero for the mesh's nodes)
                c_b[act] = np.where(dep2a[:, :, None], -np.einsum("kic,kijc->kij", d, T[j2a]) / r2[:, None], 0.0)
            small, good, step0, inv, c = small_b[sl], good_b[sl], step0_b[sl], inv_b[sl], c_b[sl]
            j2s = j2[sl]
            fr = front[sl]
            # a node hanging on a failed one, or on one done outside the domain (to be rejected), is not solved
            hang = todo & ((da & stop[ja]) | (db & stop[jb]))
            failed[lo_row + np.flatnonzero(hang)] = True
            todo &= ~hang
            # done: within the tolerance, A and B done. Every node of the fronts before the first with one not
            # within it is done (its A and B are in those fronts or done before); after it, A and B are
            # looked up until no more are done
            held = (~da | done[ja]) & (~db | done[jb])
            wide = np.flatnonzero(todo & ~small)
            k = fr[wide[0]] if wide.size else L
            now = todo & small & (held | (fr < k))
            cand = todo & small & ~now
            while cand.any():
                done[lo_row + np.flatnonzero(now)] = True
                more = cand & (~da | done[ja]) & (~db | done[jb])
                if not more.any():
                    break
                now |= more
                cand &= ~more
            if now.any():
                rows = lo_row + np.flatnonzero(now)
                done[rows] = True
                x = X[rows]
                stop[rows] = np.any((x < dom[:, 0] - self.tol_uv) | (x > dom[:, 1] + self.tol_uv), axis=1)
            # a later front's node gets a few iterations once its A and B are done
            waited[sl] += todo & held & ~now & (fr > 0)
            failed[sl] |= waited[sl] > _BAND_ITERATIONS
            go = todo & ~now & good & ~failed[sl]
            nd = np.flatnonzero(~done[lo_row:nL])
            f0 = fr[nd[0]] if nd.size else L
            # the step front after front: A's and B's steps (zero for the mesh's nodes and those done) move it
            moving = go
            dx[sl] = np.where(go[:, None], step0, 0.0)
            if go.any():
                busy = np.add.reduceat(go, bounds[f0:L] - lo_row) if f0 < L else np.zeros(0, int)
                for f in range(max(f0, 1), L):
                    if not busy[f - f0]:
                        continue
                    s = slice(bounds[f] - lo_row, bounds[f + 1] - lo_row)
                    g = slice(bounds[f], bounds[f + 1])
                    sab = np.einsum("kij,kij->ki", c[s], dx[j2s[s]])
                    dx[g] -= np.where(go[s, None], np.einsum("kij,kj->ki", inv[s], sab), 0.0)
            failed[sl] |= todo & ~done[sl] & ~good
            if moving.any():
                rows = lo_row + np.flatnonzero(moving)
                step = dx[rows]
                factor = np.min(max_step / np.maximum(np.abs(step), 1e-300), axis=1, initial=1.0)
                X[rows] += step * np.minimum(1.0, factor)[:, None]
                failed[rows[~np.all((X[rows] >= lo) & (X[rows] <= hi), axis=1)]] = True
            stop |= failed
            if it + 1 == _NEWTON_MAXIT:  # Newton's iteration limit, for the first front
                failed[:bounds[1]] |= ~done[:bounds[1]]
        return X, done & ~failed, failed, S, T[:, 0], T[:, 1]

    def _far_from_trees(self, P: np.ndarray) -> np.ndarray:
        """(k,) bool: points at least half a spacing from every node (no test
        between the points themselves).

        The nodes sit in three k-d trees: the old ones, rebuilt when the nodes
        added since outnumber an eighth of them; the middle ones, rebuilt when
        the newest outnumber an eighth of those; the newest, in a small tree
        built at every call. A front of a few nodes then costs a few small
        builds, not one of thousands (the Node Filling rounds are hundreds of
        such fronts)."""
        n = len(self.xyz)
        t = self.trees
        if "old" not in t or n - t["old"][1] > max(256, t["old"][1] // 8):
            t.clear()
            t["old"] = self._tree(0, n)
        a = t["old"][1]
        b = t["mid"][1] if "mid" in t else a
        if n - b > max(32, (b - a) // 8):
            t["mid"] = self._tree(a, n)
            b = n
        if n == b:
            t.pop("new", None)
        elif "new" not in t or t["new"][:2] != (b, n):
            t["new"] = self._tree(b, n)
        ok = np.ones(len(P), dtype=bool)
        if len(P) == 0:
            return ok
        r = 0.5 * self.rmin
        for _, _, tree in t.values():
            d, _ = tree.query(P, k=1, distance_upper_bound=r)
            ok &= d >= r
        return ok

    def fill(self) -> None:
        """Two-Neighbour fronts and Node Filling seeds in turn until neither adds a node."""
        start = None  # the first fill looks at the whole lattice; a later one only near the new seeds
        while True:
            self.two_neighbour_fill(start)
            start = self.filling_seeds()
            if len(start) == 0:
                return

    # -- step 3: node filling seeds
    def filling_seeds(self) -> np.ndarray:
        """Extend threads into unmapped gaps: at most one new node per gap.
        Returns the new nodes' positions (k, 2) (none: the drape is done)."""
        occ = self.lat.occupied()
        free = self.lat.free()
        dirs = np.array([[0, 1], [0, -1], [1, 0], [-1, 0]])
        cand_pos, cand_src, cand_prev, cand_dir = [], [], [], []
        for d in dirs:
            v = free & _shift(occ, -d[0], -d[1]) & _shift(occ, -2 * d[0], -2 * d[1])
            p = self.lat.positions(v)
            if len(p):
                cand_pos.append(p)
                cand_src.append(self.lat.at(p - d))
                cand_prev.append(self.lat.at(p - 2 * d))
                cand_dir.append(np.repeat(d[None, :], len(p), axis=0))
        if not cand_pos:
            return np.zeros((0, 2), dtype=np.int64)
        pos = np.concatenate(cand_pos)
        src = np.concatenate(cand_src)
        prv = np.concatenate(cand_prev)
        dd = np.concatenate(cand_dir)
        radius = np.where(dd[:, 1] != 0, self.s.r_weft, self.s.r_warp).astype(float)
        chord = self.xyz[src] - self.xyz[prv]
        chord /= np.linalg.norm(chord, axis=1, keepdims=True)
        normal = np.cross(self.normal[src], chord)
        guess = 2 * self.uv[src] - self.uv[prv]
        ok, uv_new, P, Pu, Pv = self.accept_uv(*_one_neighbour(self.surface, self.xyz[src], radius, normal, guess))
        ok &= np.einsum("ij,ij->i", P - self.xyz[src], chord) > 0
        if self.separated is not None and ok.any():
            w = np.flatnonzero(ok)
            ok[w] = ~self.separated(self.uv[src[w]], uv_new[w], self.xyz[src[w]], P[w])
        ok[ok] = self.far_from_mesh(P[ok])
        # a position is dead only when no source can reach it
        g = pos + self.lat.off
        reach = np.zeros(self.lat.grid.shape, dtype=bool)
        reach[g[ok, 0], g[ok, 1]] = True
        failed = pos[~reach[g[:, 0], g[:, 1]]]
        self.lat.kill(failed)
        if not ok.any():
            return np.zeros((0, 2), dtype=np.int64)
        # one seed per connected gap: the candidate farthest from the domain boundary
        mask = np.zeros(self.lat.grid.shape, dtype=bool)
        mask[g[ok, 0], g[ok, 1]] = True
        labels, _ = ndimage.label(mask, structure=np.ones((3, 3)))
        lab = labels[g[ok, 0], g[ok, 1]]
        u01 = (uv_new[ok] - self.dom[:, 0]) / (self.dom[:, 1] - self.dom[:, 0])
        inner = np.min(np.column_stack([u01, 1 - u01]), axis=1)
        order = np.lexsort((-inner, lab))
        first = order[np.r_[True, lab[order][1:] != lab[order][:-1]]]
        keep = np.flatnonzero(ok)[first]
        # two candidates may name the same position from different sources
        _, uniq = np.unique(pos[keep], axis=0, return_index=True)
        keep = keep[uniq]
        self.add(pos[keep], uv_new[keep], 3, P[keep], Pu[keep], Pv[keep])
        return pos[keep]


def check_node_count(s: DrapeSettings, area: float) -> None:
    """Refuse, up front, a mesh over a region of ``area`` estimated larger than
    ``s.max_nodes`` or than the available memory holds (a one-line SettingsError)."""
    est = estimate_node_count(area, s.r_weft, s.r_warp)
    limit, memory = node_limit(s.max_nodes)
    if est > limit:
        smallest = float(np.sqrt(area / max(limit, 1)) * np.sqrt(s.r_weft / s.r_warp))
        need = f"about {est:,} nodes and about {_bytes(est * BYTES_PER_NODE)} of memory"
        if limit < s.max_nodes:
            over = f"more than the {_bytes(memory)} available (room for about {limit:,} nodes)"
        else:
            over = f"more than the limit of {s.max_nodes:,} nodes"
        raise SettingsError(f"spacing {s.r_weft:g} needs {need}, {over}; the smallest spacing "
                            f"that fits is about {smallest:.3g}")


def drape(surface: NurbsSurface, settings: DrapeSettings, material: Material,
          area: float | None = None, progress=None, progress_interval: float = 0.06,
          inside=None) -> DrapeResult:
    """Lay the spring mesh onto the surface (paper section 3.1).

    ``area`` (the region's area, if known) lets an oversize mesh be refused up
    front with an estimate of its node count.

    ``progress(ij, uv, xyz)``, if given, is called with copies of the nodes laid
    so far, at most every ``progress_interval`` seconds, and less often when a
    report is slow (see ``REPORT_SHARE``): a live view of the drape. An
    exception it raises ends the drape there and propagates (how a caller
    stops a drape).

    ``inside(uv) -> (k,) bool``, if given, is the piece's region (a trimmed
    face, :meth:`flatweave.geometry.region.Cover.contains`): a node is laid only inside it,
    as it is only inside the domain.
    """
    t0 = time.perf_counter()
    s = settings
    for name, r in (("weft spacing", s.r_weft), ("warp spacing", s.r_warp)):
        if not (np.isfinite(r) and r > 0):
            raise SettingsError(f"{name} must be a positive number, got {r!r}")
    if s.paths not in ("plane", "geodesic"):
        raise SettingsError(f"paths must be 'plane' or 'geodesic', got {s.paths!r}")
    if not np.isfinite(s.angle_deg):
        raise SettingsError(f"angle {s.angle_deg!r} is not a number")
    if area is not None:
        check_node_count(s, area)
    b = _Builder(surface, s)
    b.inside = inside
    if progress is not None:
        last, wait = [time.perf_counter()], [progress_interval]  # end of the last report, wait after it

        def on_add():
            now = time.perf_counter()
            if now - last[0] >= wait[0]:
                progress(b.ij.copy(), b.uv.copy(), b.xyz.copy())
                last[0] = time.perf_counter()  # the report's own time is not drape time
                # dear reports (a large mesh, a slow viewer) come less often: at most a tenth of the time
                wait[0] = max(progress_interval, REPORT_SHARE * (last[0] - now))
        b.on_add = on_add
    b.seed_and_paths()
    b.fill()
    # sort nodes by lattice row, then column
    order = np.lexsort((b.ij[:, 1], b.ij[:, 0]))
    ij, uv, xyz, how = b.ij[order], b.uv[order], b.xyz[order], b.how[order]
    mesh = build_mesh(ij, s.r_weft, s.r_warp, material)
    length = np.linalg.norm(xyz[mesh.ends[:, 0]] - xyz[mesh.ends[:, 1]], axis=1)
    strain = (length - mesh.rest) / mesh.rest
    thread = mesh.kind != DIAG
    off = thread & (np.abs(strain) >= 1e-6)
    stats = {
        "nodes_seed_and_paths": int(np.sum(how <= 1)),
        "nodes_two_neighbour": int(np.sum(how == 2)),
        "nodes_filling": int(np.sum(how == 3)),
        "loop_closing_springs": int(off.sum()),
        "loop_closing_max_strain": float(np.max(np.abs(strain[off]), initial=0.0)),
        "weft_direction": b.d_weft.tolist(),
        "warp_direction": b.d_warp.tolist(),
        "seconds": time.perf_counter() - t0,
    }
    return DrapeResult(mesh=mesh, uv=uv, xyz=xyz, stats=stats)


def refill(surface: NurbsSurface, settings: DrapeSettings, ij: np.ndarray, uv: np.ndarray,
           dead_ij: np.ndarray = np.zeros((0, 2), dtype=np.int64),
           separated=None, inside=None, at=None) -> tuple[np.ndarray, np.ndarray]:
    """Node Filling from an existing mesh state (population control, paper 3.3).

    ij : (n, 2) lattice positions and uv : (n, 2) parameters of the current
    nodes; dead_ij : (k, 2) positions never to refill; separated(uv_a, uv_b,
    xyz_a, xyz_b) -> (k,) bool says where a dart lies between two points (their
    (u, v) and their points on the surface; no node is placed from a neighbour
    across a dart); at : (xyz, su, sv) (n, 3) each, the surface at uv if the
    caller has it (the solver does), or None. Returns the added nodes' (ij (a, 2),
    uv (a, 2)); the springs they form are at rest length.
    """
    b = _Builder(surface, settings)
    b.separated = separated
    b.inside = inside  # the region (a trimmed face): nodes only inside it
    b.add(np.asarray(ij, dtype=np.int64), np.asarray(uv, dtype=float), 0, *(at or ()))
    n0 = len(b.uv)
    dead = np.asarray(dead_ij, dtype=np.int64).reshape(-1, 2)
    if len(dead):
        b.lat.ensure(dead)
        b.lat.kill(dead)
    b.fill()
    return b.ij[n0:], b.uv[n0:]
