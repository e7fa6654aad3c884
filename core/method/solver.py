"""Energy minimisation over the nodes' (u, v) (paper sections 3.2 and 3.3).

Two solvers minimise the same EN (equation 4, :mod:`flatweave.method.energy`):

* ``paper``: the paper's scheme: one steepest-descent step, then
  Fletcher-Reeves conjugate gradients, each step length found by golden-section
  search; restarted with steepest descent after every change of population.
* ``fast`` (default): Levenberg-Marquardt with the exact Hessian of EN (the
  springs' 4x4 blocks with their geometric stiffness, plus the surface's
  curvature per node), assembled straight into a fixed block pattern, damped
  by lambda diag(A) and factorised by SuperLU (on the quick path by QDLDL's
  LDL^T up to 8,000 unknowns and by MKL PARDISO's Cholesky above, where the mkl wheel is
  installed, both analysed once on the round's fixed pattern). lambda starts at 1e-4 and falls
  tenfold after every step the quadratic model predicts well (rho > 0.75),
  which took fewer iterations than Nielsen's rule
  (docs/decisions/0003-levenberg-marquardt-with-the-exact-hessian.md). The
  500:1 stiffness of woven cloth, which makes gradient methods crawl, costs it
  nothing. Once the population has settled and while no node is switched off,
  the last factorisation is tried first (a chord step) and a new one made only
  when its step is not accepted (``SolverOptions.reuse``;
  docs/decisions/0025-factorisation-reuse-on-a-settled-population.md).
  With ``SolverOptions.surface_newton`` (the default;
  docs/decisions/0025-factorisation-reuse-on-a-settled-population.md)
  Newton is taken on the surface, not in its (u, v) chart:
  the Hessian's node term keeps only the normal part of each node's 3D
  gradient (the Riemannian Hessian, which is the exact one at a minimum) and
  each node's step follows the surface's geodesic to second order. At the octant's pole the chart's Christoffel
  terms made off-axis weft angles take 3-5x the on-axis iterations.

Both are generators (:func:`iterate`) that yield a :class:`Snapshot` after every
iteration, so a GUI can draw and a caller can stop within one iteration by no
longer asking for the next; :func:`minimize` drives one to the end.

Re-solves after an edit (a dart added to a converged piece) start from the
last result and move the whole mesh: a dart opening moves every node, so a
local re-solve near the new nodes saves nothing (docs/decisions/0003-levenberg-marquardt-with-the-exact-hessian.md).

Adaptive population control (3.3): a node whose (u, v) leaves the domain is
deleted with its springs; when the solver has converged, regions the mesh has
uncovered are refilled by Node Filling (:func:`flatweave.method.drape.refill`), and the
solve goes on until the population stops changing. A lattice position deleted
twice is never refilled, and the seed node is held at its (u, v) (an anchor
that removes the sliding of the whole mesh over the surface, along which the
energy barely changes).

Non-finite values stop a solve (:class:`~flatweave.errors.SolverError`): the energy,
its gradient or Hessian, or a node's (u, v) at the current iterate, or the
surface evaluated to NaN or infinity at a point inside its domain. The message
names what, the iteration and the cause. A trial step whose energy is not
finite only because nodes stepped out of the domain (where the surface's
polynomial extension can overflow) is rejected like any step that does not
lower the energy.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

try:  # LDL^T with a reusable symbolic analysis (the quick path); SuperLU without it
    import qdldl as _qdldl
except ImportError:  # pragma: no cover - a listed dependency
    _qdldl = None

from flatweave.method import pardiso
from flatweave.method.energy import Energy
from flatweave.errors import SettingsError, SolverError
from flatweave.method.lattice import DIAG, SpringMesh, bent, lattice_index
from flatweave.geometry.numerics import nan_word, nonfinite_rows
from flatweave.geometry.numerics import rowdot as _dot
from flatweave.method.metrics import spring_strain
from flatweave.method.solvers import solver_entry, solver_names

__all__ = ["SolverOptions", "Snapshot", "SolveResult", "iterate", "minimize", "State",
           "stopped_result", "STOPPED"]


@dataclass(frozen=True)
class SolverOptions:
    """method : "fast" or "paper"
    tol : stop when an iteration lowers EN by less than tol * EN
    max_iter : iteration budget (all rounds together)
    max_seconds : time budget
    anchor_seed : hold the seed node M[0, 0] at its (u, v)
    refill : refill uncovered regions after convergence
    delete : delete nodes that leave the domain (off: a fixed population, for
        comparing minimisers; nodes outside sit on the surface's extension)
    reuse : fast solver: once the population has settled (a refill found
        nothing) and while no node is switched off, try the last
        factorisation's step first (a chord step, one triangular solve) and
        factorise again only when it is not accepted, starting from the last
        factorisation of the rounds before; raise lambda to at least 1e-7 on a
        rejected step there; skip a refill while nothing changed since one
        found nothing. Before the population settles the path is the
        reference's (quicker steps there end on other populations). Off: the
        reference path (a factorisation every iteration, lambda doubled from
        wherever it was), which the tests compare against.
    surface_newton : fast solver: Newton on the surface rather than in its
        (u, v) chart: the Hessian's node term keeps only the normal part of
        the node's 3D gradient (the Riemannian Hessian, equal to the exact
        one at a minimum) and each node's step is carried along the
        surface's geodesic to second order. Near a pole (the octant's u = 0)
        the chart's Christoffel terms otherwise make the node blocks
        indefinite and the straight (u, v) step sag off the stiff threads:
        off-axis weft angles took 3-5x the iterations of the on-axis one.
        On (the default), a round's convergence also drops springs that
        came to cross a dart. Off: Newton in (u, v), the chart's exact
        Hessian and straight steps (docs/decisions/0029-newton-on-the-surface.md).
    dead_after : a lattice position that has lost its node this many times is
        never refilled. 2 from the drape, where the net slides and a position
        emptied once is often needed again; 1 for a start carried from a
        coarser level (:mod:`flatweave.method.multilevel`), whose population is already
        the piece's: a node that leaves it was carried a little beyond the
        edge, and refilling it only starts another round that empties it again.
    """

    method: str = "fast"
    tol: float = 1e-9
    max_iter: int = 1000
    max_seconds: float = math.inf
    anchor_seed: bool = True
    refill: bool = True
    delete: bool = True
    reuse: bool = True
    surface_newton: bool = True
    dead_after: int = 2

    def __post_init__(self):
        methods = solver_names("spring", iterative=True)  # asked now: a solver may be registered later
        if self.method not in methods:
            raise SettingsError(f"solver {self.method!r} is not one of {', '.join(methods)}")
        if not (self.tol > 0 and math.isfinite(self.tol)):
            raise SettingsError(f"tolerance must be a positive number, got {self.tol!r}")
        if not (isinstance(self.max_iter, int) and self.max_iter >= 0):
            raise SettingsError(f"max iterations must be a non-negative integer, got {self.max_iter!r}")
        if not (isinstance(self.dead_after, int) and self.dead_after >= 1):
            raise SettingsError(f"dead_after must be a positive integer, got {self.dead_after!r}")


@dataclass(frozen=True)
class State:
    """A mesh and its nodes' parameters: what a solve starts from and returns."""

    mesh: SpringMesh
    uv: np.ndarray


@dataclass(frozen=True)
class Snapshot:
    """One iteration of a solve (a copy: safe to keep and hand to another thread).

    iteration : iterations so far; energy : EN; nfev : energy evaluations so far
    mesh, uv (n, 2), xyz (n, 3), strain (m,) : the current state
    population_changed : nodes were deleted or added in this iteration
    """

    iteration: int
    energy: float
    nfev: int
    mesh: SpringMesh
    uv: np.ndarray
    xyz: np.ndarray
    strain: np.ndarray
    population_changed: bool
    seconds: float


@dataclass(frozen=True)
class SolveResult:
    """Like scipy's OptimizeResult: x (= uv), fun (= EN), nit, nfev, status, success, message."""

    mesh: SpringMesh
    uv: np.ndarray
    xyz: np.ndarray
    fun: float
    nit: int
    nfev: int
    status: int  # 0 converged, 1 iteration budget, 2 time budget, 3 stopped by caller
    message: str
    seconds: float
    deleted: int = 0
    added: int = 0
    history: list = field(default_factory=list)

    @property
    def x(self) -> np.ndarray:
        return self.uv

    @property
    def success(self) -> bool:
        return self.status == 0


# How far out of the domain (relative to its width) a node still counts as on its edge
# (:meth:`Problem.onto_domain`).
EDGE_SLACK = 1e-7


class Problem:
    """What the solvers need beyond a state: the surface, how a population's
    topology is built, which nodes must be deleted, and how to refill.

    build(ij, uv) -> SpringMesh; cut(uv_a, uv_b, xyz_a, xyz_b) -> (m,) bool:
    the springs from a to b that build would not form (they cross a dart),
    or None; invalid(uv_old, uv_new) -> (n,) bool, or
    invalid(uv_old, uv_new, xyz_old, xyz_new) when the solver has the nodes on
    the surface at hand (S(uv_old), S(uv_new)); refill(mesh, uv, dead_ij, at) ->
    (ij_new, uv_new) of added nodes, ``at`` the surface (xyz, su, sv) at uv if
    the solver has it (or None)
    """

    def __init__(self, surface, build, yarns=(), refill=None, invalid=None, cut=None):
        self.surface = surface
        self.build = build
        self.yarns = tuple(yarns)
        self._refill = refill
        self._invalid = invalid
        self.cut = cut

    def invalid(self, uv_old: np.ndarray, uv_new: np.ndarray, xyz_old: np.ndarray | None = None,
                xyz_new: np.ndarray | None = None) -> np.ndarray:
        """(n,) bool: nodes that left the domain or crossed a dart in the step
        uv_old -> uv_new (xyz_old, xyz_new: the same nodes on the surface, if known)."""
        bad = ~self.surface.in_domain(uv_new)
        if self._invalid is not None:
            if xyz_old is None or xyz_new is None:
                bad |= self._invalid(uv_old, uv_new)
            else:
                bad |= self._invalid(uv_old, uv_new, xyz_old, xyz_new)
        return bad

    def onto_domain(self, uv: np.ndarray) -> np.ndarray:
        """``uv`` (n, 2), changed in place, with the nodes outside the domain by less than
        EDGE_SLACK of its width put back on its edge; returns it. A node row laid on the
        domain's edge (a cylinder's rims, from a seed halfway) otherwise leaves it by round-off
        and the arcs' precision (3e-9 of the width) and is deleted, a row of the piece lost."""
        d = self.surface.domain
        slack = EDGE_SLACK * (d[:, 1] - d[:, 0])
        lo, hi = d[:, 0], d[:, 1]
        below = (uv < lo) & (uv >= lo - slack)
        above = (uv > hi) & (uv <= hi + slack)
        if below.any() or above.any():
            uv[:] = np.where(below, lo, np.where(above, hi, uv))
        return uv

    def refill(self, mesh, uv, dead_ij, at=None):
        if self._refill is None:
            return np.zeros((0, 2), dtype=np.int64), np.zeros((0, 2))
        return self._refill(mesh, uv, dead_ij, at)


# ------------------------------------------------------------------ population control
class _Population:
    """Deletion bookkeeping: how often each lattice position lost its node."""

    def __init__(self, dead_after: int = 2):
        self.counts: dict[tuple[int, int], int] = {}
        self.deleted = 0
        self.added = 0
        self.dead_after = dead_after

    def record(self, ij: np.ndarray) -> None:
        for key in map(tuple, ij.tolist()):
            self.counts[key] = self.counts.get(key, 0) + 1
        self.deleted += len(ij)

    def all_dead(self, ij: np.ndarray) -> bool:
        """True if every position ij (k, 2) was deleted ``dead_after`` times or more (is never refilled)."""
        return all(self.counts.get(key, 0) >= self.dead_after for key in map(tuple, ij.tolist()))

    def dead(self) -> np.ndarray:
        """(k, 2) positions deleted ``dead_after`` times or more: never refilled."""
        dead = [k for k, c in self.counts.items() if c >= self.dead_after]
        return np.array(dead, dtype=np.int64).reshape(-1, 2)


def _delete(problem: Problem, mesh: SpringMesh, uv: np.ndarray, drop: np.ndarray, pop: _Population,
            fixed: int | None):
    """Remove nodes ``drop`` (bool mask); isolated leftovers go too."""
    if fixed is not None:
        drop[fixed] = False
    while True:
        keep = ~drop
        new = problem.build(mesh.ij[keep], uv[keep])
        deg = new.degree()
        lonely = deg == 0
        if fixed is not None and keep[fixed]:
            lonely[np.searchsorted(np.flatnonzero(keep), fixed)] = False
        if not lonely.any():
            break
        idx = np.flatnonzero(keep)[lonely]
        drop[idx] = True
    pop.record(mesh.ij[drop])
    return new, uv[keep]


class _PlanePin:
    """A node held to a plane as a hard constraint (an anchor).

    The node's Newton step is confined to the plane's tangent and the node is
    put back on the plane after every step (a retraction); no term is added
    to the energy. See :func:`_anchors` for where pins go.
    """

    def __init__(self, surface, ij: tuple[int, int], normal: np.ndarray, point: np.ndarray):
        self.surface = surface
        self.ij = ij
        self.normal = normal / np.linalg.norm(normal)
        self.d = -float(self.normal @ point)

    def constraint(self, uv_node: np.ndarray, surface_newton: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Gradient (2,) and Hessian (2, 2) in (u, v) of the plane function
        c = n . S(u, v) + d at the node (for the Lagrangian's Hessian);
        ``surface_newton``: its Hessian on the surface (the plane normal's
        part along the surface normal only, as for the energy's node term)."""
        ev = self.surface.evaluate(uv_node[None, :], second=True)
        n = self.normal
        grad = np.array([n @ ev.su[0], n @ ev.sv[0]])
        h = _curvature_force(n[None, :], ev.su, ev.sv)[0] if surface_newton else n
        hess = np.array([[h @ ev.suu[0], h @ ev.suv[0]], [h @ ev.suv[0], h @ ev.svv[0]]])
        return grad, hess

    def off_plane_uv(self, uv_node: np.ndarray) -> np.ndarray:
        """(2,) unit direction in (u, v) that leaves the plane fastest."""
        _, Su, Sv = self.surface.derivatives(uv_node[None, :])
        grad = np.array([self.normal @ Su[0], self.normal @ Sv[0]])
        norm = np.linalg.norm(grad)
        return grad / norm if norm > 0 else np.zeros(2)

    def retract(self, uv: np.ndarray, node: int | None) -> None:
        """Move node's (u, v) back onto the plane (a few scalar Newton steps)."""
        if node is None:
            return
        p = uv[node].copy()
        for _ in range(8):
            S, Su, Sv = self.surface.derivatives(p[None, :])
            f = float(self.normal @ S[0]) + self.d
            grad = np.array([self.normal @ Su[0], self.normal @ Sv[0]])
            gg = float(grad @ grad)
            if gg == 0 or abs(f) < 1e-15:
                break
            p = p - f * grad / gg
        uv[node] = p


def _node_at(mesh: SpringMesh, ij) -> int | None:
    """Index of the node at lattice position ij (None if there is none)."""
    if ij is None:
        return None
    hit = np.flatnonzero((mesh.ij[:, 0] == ij[0]) & (mesh.ij[:, 1] == ij[1]))
    return int(hit[0]) if hit.size else None


def _anchors(problem: Problem, mesh: SpringMesh, uv: np.ndarray, options: SolverOptions):
    """The anchors that keep the mesh from drifting: (fixed lattice position, pin).

    The energy barely changes when the whole mesh slides or turns over the
    surface, and nodes that slide out are deleted: the mesh-drift trap. So:

    * no yarn constraints: the seed M[0, 0] is fixed at its (u, v), and its
      weft neighbour M[0, 1] (or M[0, -1]) is pinned to the plane through the
      seed containing its normal and the chord to that neighbour: the weft
      direction the user chose at the seed stays where it was put;
    * yarn constraints fix the orientation themselves, so there is no pin;
      the seed stays fixed, unless it lies on a constrained yarn: then it is
      pinned to the plane across that yarn (normal along the yarn), so the
      yarn's plane holds it one way and the pin the other.
    """
    if not options.anchor_seed:
        return None, None
    seed = _node_at(mesh, (0, 0))
    if seed is None:
        return None, None
    surface = problem.surface

    def chord_to(ij):
        n = _node_at(mesh, ij)
        if n is None:
            return None
        ev = surface.evaluate(uv[[seed, n]])
        return ev.normal[0], ev.xyz[0], ev.xyz[1] - ev.xyz[0]

    if not problem.yarns:
        for j in (1, -1):
            got = chord_to((0, j))
            if got is not None:
                n0, p0, chord = got
                normal = np.cross(n0, chord)
                if np.linalg.norm(normal) > 0:
                    return (0, 0), _PlanePin(surface, (0, j), normal, p0)
        return (0, 0), None
    for y in problem.yarns:
        if seed in set(y.nodes(mesh).tolist()):
            steps = ((0, 1), (0, -1)) if y.kind == "weft" else ((1, 0), (-1, 0))
            for ij in steps:
                got = chord_to(ij)
                if got is not None:
                    _, p0, chord = got
                    return None, _PlanePin(surface, (0, 0), chord, p0)
            return None, None
    return (0, 0), None


# ------------------------------------------------------------------ non-finite values
def _nodes(n: int) -> str:
    return f"{n:,} node{'s' if n != 1 else ''}"


def _surface_cause(surface, uv: np.ndarray, ev=None) -> str | None:
    """What is not finite in the surface's evaluation at ``uv`` (None: nothing)."""
    uv = np.asarray(uv, dtype=float).reshape(-1, 2)
    bad_uv = nonfinite_rows(uv)
    if bad_uv.any():
        return f"{_nodes(int(bad_uv.sum()))} had a non-finite (u, v)"
    if ev is None or ev.suu is None:
        ev = surface.evaluate(uv, second=True)
    for name, arrays in (("point", (ev.xyz,)), ("first derivative", (ev.su, ev.sv)),
                         ("second derivative", (ev.suu, ev.suv, ev.svv))):
        bad = np.zeros(len(uv), dtype=bool)
        for arr in arrays:
            bad |= nonfinite_rows(arr)
        if bad.any():
            inside = int((bad & surface.in_domain(uv)).sum())
            where = f", {inside:,} of them inside its domain" if inside < bad.sum() else ""
            return f"the surface evaluation returned a non-finite {name} at {_nodes(int(bad.sum()))}{where}"
    return None


def _cause(surface, uv: np.ndarray, ev=None) -> str:
    """Why a value computed at ``uv`` is not finite: the first non-finite input found."""
    return _surface_cause(surface, uv, ev) or "an overflow in the arithmetic, with every input finite"


def _not_finite(what: str, value, iteration: int, cause: str) -> SolverError:
    """The one-line error of a solve stopped by a non-finite ``value``."""
    when = f"at iteration {iteration}" if iteration > 0 else "in the starting mesh"
    return SolverError(f"{what} became {nan_word(value)} {when} ({cause}); the solve stopped and nothing was changed")


def _broken_inside(surface, uv: np.ndarray, xyz: np.ndarray, *derivs) -> bool:
    """True if the surface gave a non-finite point (or derivative) at a node
    inside its domain: the surface cannot be evaluated there, so no smaller step
    will help (outside the domain the extension may overflow: a step too long)."""
    bad = nonfinite_rows(xyz)
    for d in derivs:
        bad |= nonfinite_rows(d)
    return bool((bad & surface.in_domain(uv)).any())


# ------------------------------------------------------------------ Levenberg-Marquardt
@functools.lru_cache(maxsize=8)
def _dissection_rank(shape: tuple[int, int], leaf: int = 32) -> np.ndarray:
    """Nested-dissection rank of every cell of an (R, C) lattice rectangle.

    Springs join nodes at most one row and one column apart, so one lattice
    line splits the mesh in two; splitting the longer side in the middle,
    recursively, and numbering each separator after both halves gives an
    elimination order with little fill. Any subset of the rectangle inherits
    a good order by sorting on these ranks.
    """
    R, C = shape
    rank = np.empty((R, C), dtype=np.int64)
    counter = 0
    stack = [(0, R, 0, C, False)]
    while stack:
        i0, i1, j0, j1, is_sep = stack.pop()
        h, w = i1 - i0, j1 - j0
        if h <= 0 or w <= 0:
            continue
        if is_sep or h * w <= leaf or (h < 3 and w < 3):
            rank[i0:i1, j0:j1] = counter + np.arange(h * w).reshape(h, w)
            counter += h * w
            continue
        if h >= w:
            m = (i0 + i1) // 2
            parts = [(i0, m, j0, j1, False), (m + 1, i1, j0, j1, False), (m, m + 1, j0, j1, True)]
        else:
            m = (j0 + j1) // 2
            parts = [(i0, i1, j0, m, False), (i0, i1, m + 1, j1, False), (i0, i1, m, m + 1, True)]
        stack.extend(reversed(parts))  # first half, second half, then the separator
    rank.setflags(write=False)  # cached: a population's rounds mostly keep their lattice's extent
    return rank


def _dissection_order(ij: np.ndarray) -> np.ndarray:
    """Order of lattice nodes ij : (n, 2) with little fill (see _dissection_rank)."""
    if len(ij) == 0:
        return np.zeros(0, dtype=np.int64)
    lo = ij.min(axis=0)
    shape = tuple(int(x) for x in ij.max(axis=0) - lo + 1)
    rank = _dissection_rank(shape)[ij[:, 0] - lo[0], ij[:, 1] - lo[1]]
    return np.argsort(rank, kind="stable")


class _Upper:
    """A symmetric matrix held as its upper triangle (diagonal included) in CSR: ``data``,
    ``indptr``, ``indices`` as PARDISO takes them. ``A @ x`` is the whole matrix's product;
    :meth:`tocsc` the whole matrix (for SuperLU, where PARDISO cannot serve)."""

    def __init__(self, data: np.ndarray, indptr: np.ndarray, indices: np.ndarray):
        n = len(indptr) - 1
        self.data, self.indptr, self.indices = data, indptr, indices
        self.shape = (n, n)
        self._U = sp.csr_matrix((data, indices, indptr), shape=self.shape)  # shares the three arrays

    def __matmul__(self, x: np.ndarray) -> np.ndarray:
        U = self._U
        return U @ x + U.T @ x - U.diagonal() * x

    def tocsc(self) -> sp.csc_matrix:
        U = self._U
        return (U + U.T - sp.diags(U.diagonal())).tocsc()


class _Normal:
    """The Newton system on a 2 x 2 block-sparse pattern fixed per population.

    Free nodes (all but the anchor) are numbered in nested-dissection order;
    each owns two variables (u, v). A spring's 4 x 4 block splits into two
    diagonal blocks, summed per node by ``np.bincount``, and two off-diagonal
    blocks that are the only entries at their place (one spring joins two
    nodes). ``assemble_exact`` writes the node blocks and the springs' blocks
    into one array and makes the CSC data by one gather from it (``src_take``,
    found once per pattern); SuperLU then factorises without reordering.
    With ``upper_only`` (PARDISO's path) only the upper triangle's pattern is kept
    (``upper_csr``, ``upper_take``) and ``assemble_exact`` makes an :class:`_Upper`.
    """

    def __init__(self, energy: Energy, fixed: int | None, upper_only: bool = False):
        n = energy.n
        free = np.ones(n, dtype=bool)
        if fixed is not None:
            free[fixed] = False
        order = np.flatnonzero(free)[_dissection_order(energy.mesh.ij[free])]
        # int32 indices throughout: a large piece's index arrays are a good part of its memory
        num = np.full(n, -1, dtype=np.int32)
        num[order] = np.arange(len(order))
        self.num, self.order = num, order
        nb = len(order)
        self.nb, self.nvar = nb, 2 * nb
        a, b = num[energy.a], num[energy.b]
        self.a, self.b = a, b
        both = (a >= 0) & (b >= 0)
        self.both = both
        inner = np.flatnonzero(both)  # springs between free nodes
        # block pattern: diagonal blocks + (a, b) and (b, a) for springs between free nodes, in (row, column)
        # order (the keys are unique: one spring joins two nodes; a stable sort is the quicker here)
        rows = np.concatenate([np.arange(nb), a[inner], b[inner]]).astype(np.int64)  # the keys need 64 bits
        cols = np.concatenate([np.arange(nb), b[inner], a[inner]]).astype(np.int64)
        perm = np.argsort(rows * max(nb, 1) + cols, kind="stable")
        self._perm, self._k = perm.astype(np.int32), len(inner)
        self.indices = cols[perm].astype(np.int32)
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=nb))]).astype(np.int32)
        self.nnzb = len(perm)
        self.dir_num = num[energy.dir_nodes]
        self._csc_places(perm, inner)
        self.upper_only = upper_only
        if upper_only:
            # only the triangle PARDISO takes is kept, and assemble_exact makes only it (an _Upper): the full
            # pattern and its values are a good part of a large piece's memory
            take, indptr, indices = self._triangle(lower=True)
            self.upper_take = self.src_take[take]
            self.upper_csr = (None, indptr, indices)
            del self.src_take, self.csc_indices, self.csc_indptr
        # both ends of every spring, for one bincount per entry of the diagonal blocks
        self.ends_num = np.concatenate([a, b])
        self.ends_all = np.concatenate([energy.a, energy.b]).astype(np.int32)

    def _csc_places(self, perm: np.ndarray, inner: np.ndarray) -> None:
        """The scalar CSC pattern (``csc_indices``, ``csc_indptr``) and where each of its entries is
        in assemble_exact's one array (``src_take``): the free nodes' blocks (node c's at 4 c), then
        every spring's (a, b) block (spring s's at 4 (nb + s); a (b, a) block is its transpose).

        Found once per pattern by index arithmetic, no sort: the block pattern is symmetric, so block
        column c holds the blocks (r, c) for the r of block row c, in the same order; each is the
        mirror of the row's block (c, r) (itself on the diagonal, else the same spring's block the
        other way round), so its place is that block's base with the mirror's order of the four
        entries. Column 2 c + q then lists, for each of them, rows 2 r and 2 r + 1. (Before, the
        places were found by converting a float array of them with scipy: 8x slower, and 10 floats a
        block entry more at the peak; ``tests/test_solver_speed.py`` holds these to that conversion.)
        """
        nb, k, nnzb = self.nb, len(inner), self.nnzb
        deg = np.diff(self.indptr).astype(np.int64)
        row = np.repeat(np.arange(nb, dtype=np.int64), deg)  # each block's row c
        base = 4 * np.concatenate([np.arange(nb), nb + inner, nb + inner])[perm] - 1
        # the mirror of a spring's (a, b) block is its (b, a) block, whose entries are the (a, b) block's
        # transposed; a diagonal block's mirror is itself, a (b, a) block's the (a, b) block, row-major
        mirrored = (perm >= nb) & (perm < nb + k)
        start = 2 * self.indptr[:-1].astype(np.int64)[row] + 2 * np.arange(nnzb)
        take = np.empty(4 * nnzb, dtype=np.int32 if 4 * nnzb < 2**31 else np.int64)
        indices = np.empty(4 * nnzb, dtype=np.int32)
        rows2 = 2 * self.indices.astype(np.int64)
        for q in range(2):
            for p in range(2):
                at = start + 2 * q * deg[row] + p
                take[at] = base + np.where(mirrored, (1, 3, 2, 4)[2 * p + q], 1 + 2 * p + q)
                indices[at] = rows2 + p
        self.src_take = take
        self.csc_indices = indices
        self.csc_indptr = np.concatenate([[0], np.cumsum(np.repeat(2 * deg, 2))]).astype(np.int32)

    @functools.cached_property
    def _pos(self) -> np.ndarray:
        pos = np.empty_like(self._perm)
        pos[self._perm] = np.arange(self.nnzb)
        return pos

    # the places of the node blocks and of the springs' (a, b) and (b, a) blocks in the pattern (``assemble``)
    pos_diag = property(lambda self: self._pos[:self.nb])
    pos_ab = property(lambda self: self._pos[self.nb:self.nb + self._k])
    pos_ba = property(lambda self: self._pos[self.nb + self._k:])

    def _to_csc(self, data: np.ndarray) -> sp.csc_matrix:
        """The block data (nnzb, 4) (each block row-major) as a CSC matrix."""
        return sp.bsr_matrix((data.reshape(-1, 2, 2), self.indices, self.indptr), shape=(self.nvar, self.nvar)).tocsc()

    @functools.cached_property
    def csc_take(self) -> np.ndarray:
        """Where each entry of the CSC data is in ``assemble``'s block data (the reference path)."""
        return self._to_csc(np.arange(1.0, 4 * self.nnzb + 1)).data.astype(np.int64) - 1

    def _diag_sum(self, idx: np.ndarray, blocks: np.ndarray, out: np.ndarray) -> None:
        ok = idx >= 0
        for p in range(2):
            for q in range(2):
                out[:, p, q] += np.bincount(idx[ok], weights=blocks[ok, p, q], minlength=self.nb)

    def assemble(self, Hs: np.ndarray, Jd: np.ndarray, Hn: np.ndarray, damp_rel: float):
        """(A + damping as CSC, the damping vector) from spring blocks Hs
        (m, 4, 4), yarn rows Jd (c, 2) and node blocks Hn (n, 2, 2).
        Damping is lambda diag(A) (Marquardt)."""
        data = np.empty((self.nnzb, 2, 2))
        diag = Hn[self.order].copy()
        self._diag_sum(self.ends_num, np.concatenate([Hs[:, :2, :2], Hs[:, 2:, 2:]]), diag)
        if len(Jd):
            self._diag_sum(self.dir_num, Jd[:, :, None] * Jd[:, None, :], diag)
        d = diag[:, [0, 1], [0, 1]]
        damp = damp_rel * np.maximum(d, 1e-12 * max(d.max(initial=0.0), 1e-300))
        diag[:, 0, 0] += damp[:, 0]
        diag[:, 1, 1] += damp[:, 1]
        data[self.pos_diag] = diag
        data[self.pos_ab] = Hs[self.both, :2, 2:]
        data[self.pos_ba] = Hs[self.both, 2:, :2]
        A = sp.csc_matrix((data.reshape(-1)[self.csc_take], self.csc_indices, self.csc_indptr),
                          shape=(self.nvar, self.nvar))
        return A, damp.ravel()

    def assemble_exact(self, energy: Energy, ev, Q: np.ndarray, Jd: np.ndarray, damp_rel: float, fix=None,
                       surface_newton: bool = False, kept: _Gathered | None = None):
        """What ``_hessian_blocks`` then ``assemble`` give (A + damping as CSC, the damping
        vector), plus G (n, 3) and the scale ``big``, without the (m, 4, 4) spring blocks:
        a node's diagonal block is its Gram matrix times the sum of k c over its springs
        plus the springs' axial terms (three bincounts), the off-diagonal blocks are four
        numbers per spring. ``fix(D, big, G)`` may change the node blocks D (n, 2, 2)
        before the damping is taken from them (switched-off nodes, the pin).
        ``surface_newton``: the curvature term with the normal part of G only
        (:func:`_curvature_force`), as ``_hessian_blocks(..., surface_newton=True)``.
        ``kept``: the springs' surface data at ``ev`` that :func:`_gathered_residuals` gathered
        (the same arithmetic; gathered again when not given)."""
        S, Su, Sv = ev.xyz, ev.su, ev.sv
        a, b, n = energy.a, energy.b, energy.n
        if kept is None:
            kept = _Gathered(S, Su, Sv, a, b)
        kc = energy.k * (1.0 - energy.rest / np.maximum(kept.length, 1e-300))
        ax = energy.k - kc
        q0, q1, q2, q3 = (np.ascontiguousarray(Q[:, i]) for i in range(4))
        # one array holds the free nodes' blocks, then the springs' (a, b) blocks: the CSC data is one
        # gather from it (src_take), no block data in between
        src = np.empty(4 * (self.nb + len(a)))
        cross = src[4 * self.nb:].reshape(-1, 2, 2)
        cross[:, 0, 0] = ax * q0 * q2 - kc * kept.uu
        cross[:, 0, 1] = ax * q0 * q3 - kc * kept.uv
        cross[:, 1, 0] = ax * q1 * q2 - kc * kept.vu
        cross[:, 1, 1] = ax * q1 * q3 - kc * kept.vv
        ends = self.ends_all
        ax2 = np.concatenate([ax, ax])
        qa, qb = np.concatenate([q0, q2]), np.concatenate([q1, q3])
        kcsum = np.bincount(ends, np.concatenate([kc, kc]), minlength=n)
        D = np.empty((n, 2, 2))
        D[:, 0, 0] = kcsum * _dot(Su, Su) + np.bincount(ends, ax2 * qa * qa, minlength=n)
        D[:, 0, 1] = kcsum * _dot(Su, Sv) + np.bincount(ends, ax2 * qa * qb, minlength=n)
        D[:, 1, 1] = kcsum * _dot(Sv, Sv) + np.bincount(ends, ax2 * qb * qb, minlength=n)
        D[:, 1, 0] = D[:, 0, 1]
        big = max(float(np.abs(cross).max(initial=0.0)), float(np.abs(D).max(initial=0.0)), 1e-300)
        _, G = energy.force_xyz(S, kept.d, kept.length)
        Gc = _curvature_force(G, Su, Sv) if surface_newton else G
        D[:, 0, 0] += _dot(Gc, ev.suu)
        D[:, 0, 1] += _dot(Gc, ev.suv)
        D[:, 1, 0] = D[:, 0, 1]
        D[:, 1, 1] += _dot(Gc, ev.svv)
        if not (np.isfinite(cross).all() and np.isfinite(D).all()):
            return None, None, G, big
        if fix is not None:
            fix(D, big, G)
        diag = src[:4 * self.nb].reshape(-1, 2, 2)
        np.take(D, self.order, axis=0, out=diag)
        if len(Jd):
            self._diag_sum(self.dir_num, Jd[:, :, None] * Jd[:, None, :], diag)
        dd = diag[:, [0, 1], [0, 1]]
        damp = damp_rel * np.maximum(dd, 1e-12 * max(dd.max(initial=0.0), 1e-300))
        diag[:, 0, 0] += damp[:, 0]
        diag[:, 1, 1] += damp[:, 1]
        if self.upper_only:
            _, indptr, indices = self.upper_csr
            return _Upper(src[self.upper_take], indptr, indices), damp.ravel(), G, big
        A = sp.csc_matrix((src[self.src_take], self.csc_indices, self.csc_indptr), shape=(self.nvar, self.nvar))
        return A, damp.ravel(), G, big

    def gradient(self, Q, rs, Jd, rd, energy: Energy) -> np.ndarray:
        """J^T r over the free variables, in block order."""
        n = energy.n
        g = np.zeros((n, 2))
        w = np.sqrt(energy.k) * rs
        m = len(w)
        a, b = self.ends_all[:m], self.ends_all[m:]  # contiguous (energy.a, .b are views of the mesh's ends)
        for c in range(2):
            g[:, c] = np.bincount(a, Q[:, c] * w, minlength=n) + np.bincount(b, Q[:, 2 + c] * w, minlength=n)
            if len(rd):
                g[:, c] += np.bincount(energy.dir_nodes, Jd[:, c] * rd, minlength=n)
        return np.take(g, self.order, axis=0).ravel()

    def _triangle(self, lower: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(take, indptr, indices) of the CSC data's upper (or lower) triangle, diagonal included:
        where its entries are in the CSC data, and its own compressed columns."""
        col = np.repeat(np.arange(self.nvar, dtype=np.int32), np.diff(self.csc_indptr))
        keep = self.csc_indices >= col if lower else self.csc_indices <= col
        indptr = np.concatenate([[0], np.cumsum(np.bincount(col[keep], minlength=self.nvar))]).astype(np.int32)
        return np.flatnonzero(keep).astype(np.int32), indptr, self.csc_indices[keep].astype(np.int32)

    @functools.cached_property
    def _upper_csc(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The upper triangle for QDLDL (which otherwise takes it by scipy's triu), found once per pattern."""
        return self._triangle(lower=False)

    @functools.cached_property
    def upper_csr(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(take, indptr, indices): the upper triangle (diagonal included) in CSR, as PARDISO takes it: the
        CSC lower triangle read by rows (the matrix is symmetric). Found once per pattern."""
        return self._triangle(lower=True)

    def upper(self, A) -> sp.csc_matrix:
        """The upper triangle (diagonal included) of a matrix ``assemble`` made, as CSC."""
        take, indptr, indices = self._upper_csc
        return sp.csc_matrix((A.data[take], indices, indptr), shape=A.shape)

    def scatter(self, step: np.ndarray, n: int) -> np.ndarray:
        """(n, 2) node steps from the block-ordered variable vector."""
        out = np.zeros((n, 2))
        out[self.order] = step.reshape(-1, 2)
        return out


class _Gathered:
    """The springs' surface data at one evaluation, gathered once for the residuals and the Newton
    assembly at the same point (an accepted trial step's residuals are the next assembly's):
    ``d`` (m, 3) = S(a) - S(b), the springs' ``length``, the residuals' ``Q`` (m, 4) and the four
    products of both ends' tangents the assembly's cross blocks take (``uu`` = S_u(a).S_u(b),
    ``uv`` = S_u(a).S_v(b), ``vu`` = S_v(a).S_u(b), ``vv`` = S_v(a).S_v(b)). The ends' tangents
    themselves are not kept: 8 floats a spring less, twice over while a trial step's are alive."""

    __slots__ = ("length", "d", "Q", "uu", "uv", "vu", "vv")

    def __init__(self, S, Su, Sv, a, b):
        m = len(a)
        self.d, self.length, self.Q = np.empty((m, 3)), np.empty(m), np.empty((m, 4))
        self.uu, self.uv, self.vu, self.vv = (np.empty(m) for _ in range(4))
        take = np.take  # rows gathered by take: about 4x quicker than S[a] at (n, 3)
        # in blocks of springs, written into the outputs: each block's temporaries stay in the cache
        # (1.3x quicker at 2.5 million springs, the same numbers)
        for i in range(0, m, _GATHER_BLOCK):
            j = slice(i, i + _GATHER_BLOCK)
            ja, jb = a[j], b[j]
            d = np.subtract(take(S, ja, axis=0), take(S, jb, axis=0), out=self.d[j])
            length = np.sqrt(_dot(d, d))
            self.length[j] = length
            sua, sva = take(Su, ja, axis=0), take(Sv, ja, axis=0)
            sub, svb = take(Su, jb, axis=0), take(Sv, jb, axis=0)
            t = d / np.maximum(length, 1e-300)[:, None]
            Q = self.Q[j]
            Q[:, 0], Q[:, 1], Q[:, 2], Q[:, 3] = _dot(t, sua), _dot(t, sva), -_dot(t, sub), -_dot(t, svb)
            self.uu[j], self.uv[j] = _dot(sua, sub), _dot(sua, svb)
            self.vu[j], self.vv[j] = _dot(sva, sub), _dot(sva, svb)


_GATHER_BLOCK = 8_192


def _residuals(energy: Energy, S, Su, Sv):
    """Residuals and Jacobian blocks at surface data (S, S_u, S_v).

    Returns (rs (m,), Q (m, 4), rd (c,), Jd (c, 2)): spring residuals
    sqrt(k) (l - r); Q = t^T [S_u(a), S_v(a), -S_u(b), -S_v(b)] with t the
    spring's unit direction, so the spring's Jacobian row is sqrt(k) Q; the
    yarn residuals sqrt(k) f and their Jacobian rows.
    """
    return _gathered_residuals(energy, S, Su, Sv)[1]


def _gathered_residuals(energy: Energy, S, Su, Sv, at: _Gathered | None = None):
    """(the springs' :class:`_Gathered` data, :func:`_residuals`' tuple). ``at``: the
    gathered data of an earlier call at the same S, S_u, S_v with the same springs
    (only the constants changed: nodes switched off), reused with its Q."""
    g = _Gathered(S, Su, Sv, energy.a, energy.b) if at is None else at
    Q = g.Q  # geometry only (no k in it)
    rs = np.sqrt(energy.k) * (g.length - energy.rest)
    if energy.dir_nodes.size:
        sd = np.sqrt(energy.dir_k)
        rd = sd * energy.dir_distance(S)
        Nn = energy.dir_planes[:, :3]
        c = energy.dir_nodes
        Jd = np.column_stack([_dot(Nn, Su[c]), _dot(Nn, Sv[c])]) * sd[:, None]
    else:
        rd, Jd = np.zeros(0), np.zeros((0, 2))
    return g, (rs, Q, rd, Jd)


def _energy_floor(mesh: SpringMesh) -> float:
    """An energy below which the mesh is at rest: to round-off (strain ~ 1e-13), or
    to the precision of its bent springs' arcs (strain ~ (f - 1)^2, f = arc / chord,
    :func:`~flatweave.method.lattice.bent`), whichever is coarser."""
    f = mesh.thread_rest() / mesh.rest
    return 0.5 * float(np.dot(mesh.k, mesh.rest ** 2 * (1e-26 + (f - 1.0) ** 4)))


# A solve ends with its springs bent where the nodes are: where a converged population's rest
# lengths, bent again at its nodes, move by more than ARC_DRIFT (relative) it is solved again with
# them, at most ARC_ROUNDS times per population; while the fast solver's population is not settled
# (converged loosely), by more than ARC_LOOSE_DRIFT (decision 0057).
ARC_DRIFT = 1e-10
ARC_LOOSE_DRIFT = 1e-4
ARC_ROUNDS = 6


class Run:
    """One minimisation as a solver sees it: what a registered solver's generator
    ``solve(run)`` works on (:func:`iterate` makes it and reads it back).

    Read: ``problem`` (``surface``; ``build``, ``invalid``, ``refill``), ``options``
    (:class:`SolverOptions`: ``tol``, budgets), ``terms`` (the yarn constraints, for
    :class:`~flatweave.method.energy.Energy`), ``fixed_ij`` / ``pin`` (the anchors).
    Move: ``uv`` (n, 2), the live nodes' parameters, and ``mesh`` only through
    :meth:`remove_invalid` and :meth:`try_refill`. Count: ``nit`` per iteration,
    ``nfev`` per energy evaluation. Per iteration: stop when :meth:`budget_left` is
    False, yield :meth:`snapshot`. At the end: set ``status`` (0 converged) and
    ``message``; the energy and result are computed from ``uv`` and ``mesh``.
    """

    def __init__(self, problem: Problem, state: State, options: SolverOptions):
        self.problem = problem
        self.options = options
        self.mesh = state.mesh
        self.uv = np.array(state.uv, dtype=float)
        self.pop = _Population(options.dead_after)
        self.nit = 0
        self.nfev = 0
        self.t0 = time.perf_counter()
        self.history = []
        self.status = None
        self.message = ""
        self.terms = problem.yarns
        self.fixed_ij, self.pin = _anchors(problem, self.mesh, self.uv, options)
        self.refills: set[tuple[bytes, bytes]] = set()  # (population, positions added) of every refill made
        self.bends = 0  # times :meth:`bend` asked the paper's solver to minimise again (the fast one counts per round)

    def budget_left(self) -> bool:
        if self.nit >= self.options.max_iter:
            self.status, self.message = 1, f"stopped at the iteration budget ({self.options.max_iter})"
            return False
        if time.perf_counter() - self.t0 > self.options.max_seconds:
            self.status, self.message = 2, f"stopped at the time budget ({self.options.max_seconds:g} s)"
            return False
        return True

    def snapshot(self, energy: float, xyz: np.ndarray, changed: bool, lengths: np.ndarray | None = None) -> Snapshot:
        """``lengths``: the live springs' lengths at xyz when already known (in ``self.mesh``'s order)."""
        self.history.append(energy)
        strain = spring_strain(xyz, self.mesh) if lengths is None else lengths / self.mesh.rest - 1.0
        return Snapshot(self.nit, energy, self.nfev, self.mesh, self.uv.copy(), xyz.copy(),
                        strain, changed, time.perf_counter() - self.t0)

    def remove_invalid(self, uv_old: np.ndarray, uv_new: np.ndarray) -> bool:
        """Delete nodes that left the domain (or crossed a dart); True if any did."""
        bad = self.problem.invalid(uv_old, uv_new)
        if not self.options.delete:
            bad[:] = False
        fixed = _node_at(self.mesh, self.fixed_ij)
        if fixed is not None:
            bad[fixed] = False
        if not bad.any():
            self.uv = uv_new
            return False
        self.mesh, self.uv = _delete(self.problem, self.mesh, uv_new, bad, self.pop, fixed)
        return True

    def try_refill(self, at=None) -> bool:
        """Refill the population; ``at`` (xyz, su, sv): the surface at ``self.uv``, if known."""
        if not self.options.refill:
            return False
        ij, uv = self.problem.refill(self.mesh, self.uv, self.pop.dead(), at)
        if len(ij) == 0:
            return False
        # the same refill of the same population again: its round emptied those positions once and
        # came back here, and would again (an isotropic piece's edge, docs/decisions/0039-refill-rules-against-churn.md)
        key = (self.mesh.ij.tobytes(), ij[np.lexsort((ij[:, 1], ij[:, 0]))].tobytes())
        if key in self.refills:
            return False
        self.refills.add(key)
        all_ij = np.concatenate([self.mesh.ij, ij])
        all_uv = np.concatenate([self.uv, uv])
        order = np.lexsort((all_ij[:, 1], all_ij[:, 0]))
        self.mesh = self.problem.build(all_ij[order], all_uv[order])
        self.uv = all_uv[order]
        self.pop.added += len(ij)
        return True

    def bend(self) -> bool:
        """Bend the springs again where the live nodes are now (``mesh`` is replaced,
        so a solve ends with the springs a build at its (u, v) makes, as a result
        file reopens them); True if a rest length moved by over ARC_DRIFT and fewer
        than ARC_ROUNDS bends were made: the solver then minimises again."""
        ev = self.problem.surface.evaluate(self.uv)
        again = bent(self.mesh, ev.xyz, ev.normal)
        drift = np.max(np.abs(again.rest / self.mesh.rest - 1.0), initial=0.0)
        self.mesh = again
        if drift > ARC_DRIFT and self.bends < ARC_ROUNDS:
            self.bends += 1
            return True
        return False

    def result(self, energy: float) -> SolveResult:
        xyz = self.problem.surface.points(self.uv)
        return SolveResult(self.mesh, self.uv, xyz, energy, self.nit, self.nfev, self.status,
                           self.message, time.perf_counter() - self.t0, self.pop.deleted,
                           self.pop.added, list(self.history))


def _hessian_blocks(energy: Energy, S, Su, Sv, q, Suu, Suv, Svv, surface_newton: bool = False):
    """Newton blocks: per spring (m, 4, 4) and per node (n, 2, 2), and the
    3D energy gradient G (n, 3).

    A spring's Hessian in 3D is k [t t^T + c (I - t t^T)] with c = 1 - r/l,
    mapped to (u, v) by the surface derivatives; each node adds the
    surface-curvature term G . S_uv. This is the exact Hessian of EN: it is
    indefinite where springs are compressed, which the Levenberg-Marquardt
    damping and gain-ratio test handle; a PSD projection of the blocks would
    make the final convergence linear
    (docs/decisions/0003-levenberg-marquardt-with-the-exact-hessian.md). Checked against
    finite differences by tests/test_hessian.py.

    ``surface_newton``: the Hessian on the surface instead (the Riemannian
    Hessian in (u, v) coordinates): the node term takes only the normal part
    of G (:func:`_curvature_force`). It differs from the exact one by the
    Christoffel terms times the (u, v) gradient, so the two agree at a
    minimum (Newton's quadratic convergence is kept), but it does not blow up
    where the parametrisation degenerates (tests/test_solver_surface.py).
    """
    a, b = energy.a, energy.b
    d = S[a] - S[b]
    length = np.sqrt(_dot(d, d))
    c = 1.0 - energy.rest / np.maximum(length, 1e-300)
    kc = energy.k * c
    # k [(1 - c) q q^T + c E^T E], q = t^T E, E = [S_u(a), S_v(a), -S_u(b), -S_v(b)]
    Hs = (energy.k - kc)[:, None, None] * q[:, :, None] * q[:, None, :]
    gram = np.empty((len(S), 2, 2))
    gram[:, 0, 0] = _dot(Su, Su)
    gram[:, 0, 1] = gram[:, 1, 0] = _dot(Su, Sv)
    gram[:, 1, 1] = _dot(Sv, Sv)
    w = kc[:, None, None]
    Hs[:, :2, :2] += w * gram[a]
    Hs[:, 2:, 2:] += w * gram[b]
    Sua, Sva, Sub, Svb = Su[a], Sv[a], Su[b], Sv[b]
    Hs[:, 0, 2] -= kc * _dot(Sua, Sub)
    Hs[:, 0, 3] -= kc * _dot(Sua, Svb)
    Hs[:, 1, 2] -= kc * _dot(Sva, Sub)
    Hs[:, 1, 3] -= kc * _dot(Sva, Svb)
    Hs[:, 2:, :2] = Hs[:, :2, 2:].transpose(0, 2, 1)
    _, G = energy.force_xyz(S)
    Gc = _curvature_force(G, Su, Sv) if surface_newton else G
    Hn = np.empty((energy.n, 2, 2))
    Hn[:, 0, 0] = _dot(Gc, Suu)
    Hn[:, 0, 1] = Hn[:, 1, 0] = _dot(Gc, Suv)
    Hn[:, 1, 1] = _dot(Gc, Svv)
    return Hs, Hn, G


def _pin_block(pin: _PlanePin, uv_node: np.ndarray, G_node: np.ndarray, su_node: np.ndarray,
               sv_node: np.ndarray, big: float, surface_newton: bool = False) -> np.ndarray:
    """(2, 2) added to the pinned node's Newton block: the Lagrangian's term
    -mu H_c (mu the multiplier of the plane constraint c at the current
    gradient) and a stiff penalty across the plane, so the node's step stays
    in the plane's tangent (and the retraction corrects the rest). With
    ``surface_newton`` H_c is the constraint's Hessian on the surface, to go
    with the energy's: their Christoffel terms cancel at the constrained
    minimum, where the gradient is mu times the constraint's."""
    cg_, ch_ = pin.constraint(uv_node, surface_newton)
    g_uv = np.array([G_node @ su_node, G_node @ sv_node])
    mu = float(g_uv @ cg_) / float(cg_ @ cg_)  # Lagrange multiplier
    off = cg_ / np.linalg.norm(cg_)
    return 1e8 * big * np.outer(off, off) - mu * ch_


_QDLDL_MAX = 8_000
"""Largest system (unknowns, about 4,000 nodes) factorised by QDLDL: its binding holds the GIL
while it factorises (SuperLU's releases it), so a GUI's event loop waits for every factorisation
(about 20 ms at 2,500 nodes, 200 ms at 10,000, where it is only 1.15x faster than SuperLU)."""


PARDISO_MIN = _QDLDL_MAX + 1
"""Smallest system (unknowns) factorised by MKL PARDISO's Cholesky on the quick path, where it is
available (:mod:`flatweave.method.pardiso`): analysed once per round, refactorised in place,
the GIL released; 3 to 5x quicker than SuperLU from 20,000 unknowns and 2.1x less memory
(docs/decisions/0075-pardiso-for-large-systems.md). A matrix that is not positive definite goes
to SuperLU, as where PARDISO is not available."""


class _Round:
    """One population of the fast solver: a fixed node set and sparse pattern.

    Nodes that leave the domain during the round are switched off rather than
    removed (their springs get k = 0, their variables an identity block), so
    the pattern and the last factorisation stay usable; ``run.mesh`` and
    ``run.uv`` always hold the compact live population.
    """

    def __init__(self, run: Run):
        self.run = run
        self.mesh = run.mesh
        self.uv = run.uv.copy()
        self.full = Energy(run.problem.surface, self.mesh, run.terms)
        self.energy = self.full
        self.fixed = _node_at(self.mesh, run.fixed_ij)
        # on PARDISO's path (quick factorisations of systems QDLDL does not take) only its triangle is made
        nvar = 2 * (self.full.n - (self.fixed is not None))
        upper_only = run.options.reuse and nvar >= PARDISO_MIN and pardiso.available() \
            and not (_qdldl is not None and nvar <= _QDLDL_MAX)
        self.normal = _Normal(self.full, self.fixed, upper_only)
        self.alive = np.ones(self.mesh.n_nodes, dtype=bool)
        self.floor = _energy_floor(self.mesh)
        self.settled = False  # True once a refill found nothing to add
        self.spring_on = np.ones(self.mesh.n_springs, dtype=bool)
        self._corners, self._cell_edges = _round_topology(self.mesh)
        self._ldl = None  # the round's QDLDL factorisation (quick path)
        self._chol = None  # the round's PARDISO Cholesky (quick path, large systems), analysed once
        self.bends = 0  # times its springs were bent again (:meth:`bend`)

    def switch_off(self, bad: np.ndarray, xyz: np.ndarray) -> np.ndarray:
        """Delete nodes ``bad`` (and nodes left without springs); xyz : (n, 3)
        the round's nodes on the surface now. Returns the lattice positions
        (k, 2) of the nodes switched off.

        The springs left are the round's springs that the population's own
        build would still form: both ends alive, a diagonal only while one of
        its cell's other corners is, none crossing a dart where the nodes are
        now. They are found by masks over the round's arrays (no rebuild,
        no surface evaluation), and ``run.mesh`` is the round's mesh filtered
        by them. (A spring a dart cut at the start of the round that no
        longer crosses it stays out until the next build, when nodes are
        refilled: it is not in the energy minimised, so it is not in the mesh
        either. Forming it again at once was tried: a spring at the edge of a
        plane dart's box can then go in and out for ever, each state's
        minimum cutting or restoring it.)
        """
        run, mesh = self.run, self.mesh
        if self.fixed is not None:
            bad[self.fixed] = False
        alive = self.alive & ~bad
        a, b = mesh.ends[:, 0], mesh.ends[:, 1]
        uncut = np.ones(mesh.n_springs, dtype=bool)
        if run.problem.cut is not None:
            uncut = ~_cut_at(run.problem.cut, self.uv, xyz, a, b)
        c1, c2 = self._corners[:, 0], self._corners[:, 1]
        thread = self.mesh.kind != DIAG
        while True:
            on = uncut & alive[a] & alive[b]
            corner = np.append(alive, False)  # an empty corner (-1) is not alive
            on &= thread | corner[c1] | corner[c2]
            lonely = alive & (np.bincount(mesh.ends[on].ravel(), minlength=mesh.n_nodes) == 0)
            if self.fixed is not None:
                lonely[self.fixed] = False
            if not lonely.any():
                break
            alive &= ~lonely
        gone = mesh.ij[self.alive & ~alive]
        run.pop.record(gone)
        self.alive, self.spring_on = alive, on
        self.energy = self.full.masked(on, alive)
        idx = np.flatnonzero(alive)
        num = np.full(mesh.n_nodes, -1, dtype=np.int64)
        num[idx] = np.arange(len(idx))
        cells = mesh.cells[alive[mesh.cells].all(axis=1) & on[self._cell_edges].all(axis=1)]
        run.mesh = dataclasses.replace(mesh, ij=mesh.ij[idx], ends=num[mesh.ends[on]], kind=mesh.kind[on],
                                       rest=mesh.rest[on], k=mesh.k[on], cells=num[cells])
        run.uv = self.uv[idx]
        return gone

    def bend(self, ev, loose: bool = False) -> bool:
        """Bend the round's springs again where its nodes are (``ev``: the surface at
        ``self.uv``): True if a live spring's rest length moved by over ARC_DRIFT
        (ARC_LOOSE_DRIFT when ``loose``: converged loosely, the round to settle yet)
        and the round has bends left; the energy (and ``run.mesh``) then has the new
        ones. The population, its pattern and its last factorisation stay."""
        run = self.run
        if self.bends >= ARC_ROUNDS:
            return False
        again = bent(self.mesh, ev.xyz, run.problem.surface.normals(self.uv, ev.su, ev.sv))
        on = self.spring_on
        drift = np.max(np.abs(again.rest[on] / self.mesh.rest[on] - 1.0), initial=0.0)
        if not drift > (ARC_LOOSE_DRIFT if loose else ARC_DRIFT):
            return False
        self.bends += 1
        self.mesh = again
        self.full = self.full.rebent(again)
        self.energy = self.full if on.all() and self.alive.all() else self.full.masked(on, self.alive)
        self.floor = _energy_floor(again)
        run.mesh = dataclasses.replace(run.mesh, rest=again.rest[on], k=again.k[on])
        return True

    def surface_at(self, ev) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(xyz, su, sv) of the live nodes (``run.uv``), from the round's evaluation ``ev``."""
        if self.alive.all():
            return ev.xyz, ev.su, ev.sv
        return ev.xyz[self.alive], ev.su[self.alive], ev.sv[self.alive]

    def crossing(self, xyz: np.ndarray) -> bool:
        """True if a live spring crosses a dart where its nodes are now (xyz : (n, 3))."""
        cut = self.run.problem.cut
        on = np.flatnonzero(self.spring_on)
        if cut is None or not len(on):
            return False
        a, b = self.mesh.ends[on, 0], self.mesh.ends[on, 1]
        return bool(_cut_at(cut, self.uv, xyz, a, b).any())

    def release_factor(self) -> None:
        """Free the round's PARDISO factor (kept: its analysis), once it is never to serve again."""
        if self._chol is not None:
            self._chol.release_factor()

    def factorise(self, A, quick: bool = False):
        """Factorisation of A: SuperLU in the pattern's own order (nested
        dissection; no iterative solver or other ordering measured was
        faster, docs/decisions/0003-levenberg-marquardt-with-the-exact-hessian.md), or with
        ``quick`` QDLDL's LDL^T, whose
        symbolic analysis is made once per round (the round's pattern is
        fixed) and then only refactorised: 1.7x faster at 2,500 nodes
        (docs/decisions/0028-qdldl-for-small-systems.md). Both factorise without
        pivoting; where QDLDL fails (a zero pivot) SuperLU decides, so a
        singular matrix is treated as on the reference path.

        The QDLDL object is refactorised in place: a factorisation returned
        earlier in the round is no longer valid after the next one (the
        solver keeps at most the last one)."""
        if quick and _qdldl is not None and A.shape[0] <= _QDLDL_MAX:
            try:
                U = self.normal.upper(A)
                if self._ldl is None:
                    self._ldl = _qdldl.Solver(U, upper=True)
                else:
                    self._ldl.update(U, upper=True)
                return self._ldl
            except Exception:  # QDLDL raises plain errors on a zero pivot
                self._ldl = None
        if quick and A.shape[0] >= PARDISO_MIN and pardiso.available():
            take, indptr, indices = self.normal.upper_csr
            try:
                if self._chol is None:
                    self._chol = pardiso.Cholesky(indptr, indices)
                if self._chol.factor(A.data if isinstance(A, _Upper) else A.data[take]):
                    return self._chol
            except RuntimeError:  # PARDISO refused the pattern or failed: SuperLU decides, as below
                self._chol = None
        if isinstance(A, _Upper):
            A = A.tocsc()
        return splu(A, permc_spec="NATURAL", diag_pivot_thresh=0.0, options={"SymmetricMode": True})

    def solve(self, A, g: np.ndarray) -> np.ndarray:
        """A x = -g (one factorisation)."""
        return self.factorise(A).solve(-g)


def _cut_at(cut, uv: np.ndarray, xyz: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``cut`` (a dart test) on the springs a -> b where the nodes are now; rows gathered by np.take,
    several times quicker than fancy indexing here."""
    take = np.take
    return cut(take(uv, a, axis=0), take(uv, b, axis=0), take(xyz, a, axis=0), take(xyz, b, axis=0))


def _round_topology(mesh: SpringMesh) -> tuple[np.ndarray, np.ndarray]:
    """What :meth:`_Round.switch_off` needs to drop springs and cells by masks.

    Returns (corners (m, 2): for a diagonal spring the nodes at its cell's
    other two corners, -1 where a corner is empty, and -1 for both of a weft or
    warp spring; cell_edges (c, 4): the springs along the four edges of every
    cell).
    """
    grid, off = lattice_index(mesh.ij)
    take = np.take  # rows by take: several times quicker than fancy indexing at (n, 2)
    pa, pb = take(mesh.ij, mesh.ends[:, 0], axis=0) - off, take(mesh.ij, mesh.ends[:, 1], axis=0) - off
    corners = np.column_stack([grid[pa[:, 0], pb[:, 1]], grid[pb[:, 0], pa[:, 1]]])
    thread = mesh.kind != DIAG
    corners[thread] = -1
    # every weft (warp) spring by the lattice position of its end with the smaller j (i): two lookup grids
    t = np.flatnonzero(thread)
    lo = np.minimum(pa[t], pb[t])
    weft = pa[t, 0] == pb[t, 0]
    by_lo = np.full((2,) + grid.shape, -1, dtype=np.int64)  # [0]: weft springs, [1]: warp springs
    by_lo[np.where(weft, 0, 1), lo[:, 0], lo[:, 1]] = t
    cells = mesh.cells
    edges = np.empty((len(cells), 4), dtype=np.int64)
    for c, (s, u) in enumerate(((0, 1), (1, 2), (3, 2), (0, 3))):
        ps, pu = take(mesh.ij, cells[:, s], axis=0) - off, take(mesh.ij, cells[:, u], axis=0) - off
        lo = np.minimum(ps, pu)
        edges[:, c] = by_lo[np.where(ps[:, 0] == pu[:, 0], 0, 1), lo[:, 0], lo[:, 1]]  # every edge is a spring
    return corners, edges


def _curvature_force(G: np.ndarray, Su: np.ndarray, Sv: np.ndarray) -> np.ndarray:
    """(n, 3) the part of G (n, 3) along the surface's unit normal (S_u x S_v).

    The exact Hessian's node term G . S_ij splits into (G . N) N . S_ij, the
    surface's second fundamental form, and the tangential part, which is the
    Christoffel symbols times the (u, v) gradient: a property of the
    coordinates, not of the energy. Near a pole (S_v ~ u) that part grows
    like |G| u against the springs' k u^2 and makes the node's block
    indefinite, so the Newton step asks for huge (u, v) moves. Where the
    normal is undefined (at the pole itself) G is kept whole.
    """
    n = np.cross(Su, Sv)
    ln = np.sqrt(_dot(n, n))
    ok = ln > 1e-7 * np.maximum(_dot(Su, Su), _dot(Sv, Sv))
    n = n / np.where(ok, ln, 1.0)[:, None]
    return np.where(ok[:, None], _dot(G, n)[:, None] * n, G)


def _geodesic_correction(ev, d: np.ndarray) -> np.ndarray:
    """(n, 2) second-order correction of the (u, v) steps d (n, 2): the
    step d taken as a tangent vector and followed along the surface's
    geodesic, uv + d - Gamma(d, d) / 2, instead of along a straight (u, v)
    line, whose point drifts sideways by S_ij d_i d_j / 2 (on a circle of
    latitude near a pole: a stiff thread stretched by the chord's sag).

    Gamma(d, d) is the tangential part of S_ij d_i d_j in the basis
    (S_u, S_v). Where the expansion cannot hold (the correction larger than
    half the step: a step across a pole) or the metric is singular, the step
    is left as it is.
    """
    d0, d1 = d[:, 0], d[:, 1]
    a = ev.suu * (d0 * d0)[:, None] + ev.suv * (2 * d0 * d1)[:, None] + ev.svv * (d1 * d1)[:, None]
    b0, b1 = _dot(ev.su, a), _dot(ev.sv, a)
    e, f, g = _dot(ev.su, ev.su), _dot(ev.su, ev.sv), _dot(ev.sv, ev.sv)
    det = e * g - f * f
    ok = det > 1e-14 * np.maximum(e, g) ** 2
    det = np.where(ok, det, 1.0)
    corr = -0.5 * np.column_stack([(g * b0 - f * b1) / det, (e * b1 - f * b0) / det])
    corr[~ok | (np.abs(corr).max(axis=1) > 0.5 * np.abs(d).max(axis=1))] = 0.0
    return corr


_LAM_JUMP = 1e-7
"""A rejected step raises lambda to at least this: after a run of good steps lambda can
reach 1e-18, and doubling from there took 8 rejected factorisations
(docs/decisions/0025-factorisation-reuse-on-a-settled-population.md)."""


def iterate_fast(run: Run):
    surface = run.problem.surface
    opts = run.options
    lam, nu = 1e-4, 2.0
    eye = np.eye(2)
    loose = max(opts.tol, 1e-3)
    # the last factorisation, while it may serve again: (lu, A, damp) of this round, made after
    # its last switch-off, its step accepted (a chord step's model is that matrix, undamped)
    stale = None
    # the last factorisation made since the last change of population, its step accepted (or its Newton
    # decrement small): once the population settles it serves the first chord step, which saves the
    # factorisation the settled round would start with
    held = None
    last_decrease = math.inf
    # a refill found nothing and no node was switched off since, but at positions never refilled (deleted
    # twice): taking a node away gives no empty position two neighbours, so that refill would find nothing again
    quiet = False

    def start():
        rd_ = _Round(run)
        ev_ = surface.evaluate(rd_.uv, second=True, normals=False)
        run.nfev += 1
        kept_, res = _gathered_residuals(rd_.energy, ev_.xyz, ev_.su, ev_.sv)
        E_ = 0.5 * (res[0] @ res[0] + res[2] @ res[2])
        if not math.isfinite(E_):
            raise _not_finite("the energy", E_, run.nit, _cause(surface, rd_.uv, ev_))
        return rd_, ev_, res, E_, kept_

    rnd, ev, (rs, Q, rd, Jd), E, kept = start()
    while True:
        converged = E <= rnd.floor
        if not converged and not run.budget_left():
            yield run.snapshot(E, ev.xyz[rnd.alive], False, kept.length[rnd.spring_on])
            return
        chord = False
        # chord steps and the lambda jump only once the population has settled: before, they change which
        # nodes leave and the solve can end on another population (on curve darts up to 1.3 points of
        # boundary error, docs/decisions/0025-factorisation-reuse-on-a-settled-population.md)
        quick = opts.reuse and rnd.settled
        if not converged:
            energy, normal = rnd.energy, rnd.normal
            pinned = _node_at(rnd.mesh, run.pin.ij) if run.pin is not None else None
            if stale is not None:  # a chord step on the last factorisation
                g = normal.gradient(Q, rs, Jd, rd, energy)
                if not np.isfinite(g).all():
                    raise _not_finite("the energy's gradient", g, run.nit + 1, _cause(surface, rnd.uv, ev))
                lu, A, damp = stale
                step = lu.solve(-g)
                chord = bool(np.isfinite(step).all())
                if not chord:
                    stale = None
            if not chord:
                # one factorisation alive at a time: once a new one is made the last is never used again (every
                # branch below keeps the new one, or none), and a large piece's factor is most of its memory
                stale = held = lu = None
                A = damp = None  # the last matrix too: not alive beside the new one while it is assembled
                rnd.release_factor()  # and PARDISO's factor (its analysis stays for the next)
                def fix(Hn, big, G):
                    if not rnd.alive.all():  # switched-off nodes keep still
                        Hn[~rnd.alive] = eye * big
                    if pinned is not None:  # the orientation anchor moves along its plane only
                        Hn[pinned] += _pin_block(run.pin, rnd.uv[pinned], G[pinned], ev.su[pinned], ev.sv[pinned],
                                                 big, opts.surface_newton)

                if opts.reuse:
                    A, damp, G, big = normal.assemble_exact(energy, ev, Q, Jd, lam, fix, opts.surface_newton,
                                                            kept)
                    if A is None:
                        Hs, Hn, G = _hessian_blocks(energy, ev.xyz, ev.su, ev.sv, Q, ev.suu, ev.suv, ev.svv)
                        bad = Hs if not np.isfinite(Hs).all() else Hn
                        raise _not_finite("the energy's Hessian", bad, run.nit + 1, _cause(surface, rnd.uv, ev))
                else:  # the reference path: the spring blocks, then their assembly
                    Hs, Hn, G = _hessian_blocks(energy, ev.xyz, ev.su, ev.sv, Q, ev.suu, ev.suv, ev.svv,
                                                opts.surface_newton)
                    if not (np.isfinite(Hs).all() and np.isfinite(Hn).all()):
                        bad = Hs if not np.isfinite(Hs).all() else Hn
                        raise _not_finite("the energy's Hessian", bad, run.nit + 1, _cause(surface, rnd.uv, ev))
                    fix(Hn, max(float(np.abs(Hs).max(initial=0.0)), 1e-300), G)
                    A, damp = normal.assemble(Hs, Jd, Hn, lam)
                g = normal.gradient(Q, rs, Jd, rd, energy)
                if not np.isfinite(g).all():
                    raise _not_finite("the energy's gradient", g, run.nit + 1, _cause(surface, rnd.uv, ev))
                try:
                    lu = rnd.factorise(A, quick=opts.reuse)
                    step = lu.solve(-g)
                    if not np.isfinite(step).all():
                        raise RuntimeError("non-finite step")
                except RuntimeError:  # singular: damp harder
                    lam *= 10
                    run.nit += 1
                    continue
            # decrease predicted by the undamped quadratic model (a chord step's: the factorised matrix)
            pred = -float(g @ step) - 0.5 * float(step @ (A @ step) - (damp * step) @ step)
            tol_now = opts.tol if rnd.settled else loose
            if 0 <= pred <= 0.1 * tol_now * E and lam <= 1e-2:
                converged = True  # the Newton decrement says we are there
                if opts.reuse and not chord:
                    held = (lu, A, damp)
        if not converged:
            dstep = normal.scatter(step, energy.n)
            uv_try = rnd.uv + dstep
            if opts.surface_newton:
                uv_try += _geodesic_correction(ev, dstep)
            run.problem.onto_domain(uv_try)
            if pinned is not None:
                before = uv_try[pinned].copy()
                run.pin.retract(uv_try, pinned)
                if not np.isfinite(uv_try[pinned]).all():
                    raise _not_finite("the (u, v) of the node held to the weft plane", uv_try[pinned], run.nit + 1,
                                      _surface_cause(surface, before) or "its retraction onto the plane diverged")
            # a trial step far out of the domain may overflow the surface's extension there: the
            # non-finite energy is handled below (rejected, or an error when it is broken inside)
            with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
                ev2 = surface.evaluate(uv_try, second=True, normals=False)
                kept2, (rs2, Q2, rd2, Jd2) = _gathered_residuals(energy, ev2.xyz, ev2.su, ev2.sv)
                E2 = 0.5 * (rs2 @ rs2 + rd2 @ rd2)
            run.nfev += 1
            if not np.isfinite(E2) and _broken_inside(surface, uv_try, ev2.xyz, ev2.su, ev2.sv):
                raise _not_finite("the energy", E2, run.nit + 1, _cause(surface, uv_try, ev2))
            rho = (E - E2) / pred if pred > 0 else -1.0
            if chord and not (np.isfinite(E2) and rho > 0.5):
                stale = None  # the old matrix no longer models EN well: factorise (same iteration)
                continue
            run.nit += 1
            if np.isfinite(E2) and rho > 1e-4:
                decrease = E - E2
                lam *= 0.1 if rho > 0.75 else max(1 / 3, 1 - (2 * rho - 1) ** 3)
                nu = 2.0
                bad = run.problem.invalid(rnd.uv, uv_try, ev.xyz, ev2.xyz) & rnd.alive & opts.delete
                rnd.uv = uv_try
                run.uv = uv_try[rnd.alive]
                ev = ev2
                if bad.any():
                    stale, held = None, None
                    gone = rnd.switch_off(bad, ev.xyz)
                    quiet = quiet and opts.reuse and run.pop.all_dead(gone)
                    kept, (rs, Q, rd, Jd) = _gathered_residuals(rnd.energy, ev.xyz, ev.su, ev.sv, at=kept2)
                    E = 0.5 * (rs @ rs + rd @ rd)
                    if not math.isfinite(E):
                        raise _not_finite("the energy", E, run.nit, _cause(surface, rnd.uv[rnd.alive]))
                    yield run.snapshot(E, ev.xyz[rnd.alive], True, kept.length[rnd.spring_on])
                    continue
                if opts.reuse and not chord:
                    held = (lu, A, damp)
                if quick and not chord:
                    stale = held
                elif chord and decrease > 0.1 * last_decrease:
                    stale = None  # the chord steps converge slowly: a new factorisation will do better
                last_decrease = decrease
                rs, Q, rd, Jd, E, kept = rs2, Q2, rd2, Jd2, E2, kept2
                yield run.snapshot(E, ev.xyz[rnd.alive], False, kept.length[rnd.spring_on])
                # until the population has settled, a loose tolerance will do
                converged = decrease <= (opts.tol if rnd.settled else loose) * (E + decrease)
            else:
                stale = held = None
                lam = max(lam * nu, _LAM_JUMP) if quick else lam * nu
                nu *= 2
                yield run.snapshot(E, ev.xyz[rnd.alive], False, kept.length[rnd.spring_on])
                converged = lam > 1e16  # no step lowers EN: at the minimum to round-off
        if converged:
            # a spring that came to cross a dart without either end crossing it (swung round the
            # dart's end) is not in the piece: drop it and go on (switch_off re-checks every spring)
            if opts.surface_newton and opts.delete and run.problem.cut is not None and rnd.crossing(ev.xyz):
                stale, held = None, None
                gone = rnd.switch_off(np.zeros(rnd.mesh.n_nodes, dtype=bool), ev.xyz)
                quiet = quiet and opts.reuse and run.pop.all_dead(gone)
                # before settling the round would only confirm its loose convergence on the springs left
                # (one more factorisation) and then refill: refill at once
                # (docs/decisions/0039-refill-rules-against-churn.md)
                if opts.reuse and not rnd.settled and not quiet:
                    if run.try_refill(rnd.surface_at(ev)):
                        rnd, ev, (rs, Q, rd, Jd), E, kept = start()
                        yield run.snapshot(E, ev.xyz, True, kept.length)
                        continue
                    quiet = True  # found nothing, and no node has left since
                kept, (rs, Q, rd, Jd) = _gathered_residuals(rnd.energy, ev.xyz, ev.su, ev.sv, at=kept)
                E = 0.5 * (rs @ rs + rd @ rd)
                yield run.snapshot(E, ev.xyz[rnd.alive], True, kept.length[rnd.spring_on])
                continue
            # the nodes moved the arcs under the springs: minimise again with them (loosely bent while the
            # round has yet to settle; at the energy floor it will not)
            if rnd.bend(ev, loose=not rnd.settled and E > rnd.floor):
                kept, (rs, Q, rd, Jd) = _gathered_residuals(rnd.energy, ev.xyz, ev.su, ev.sv, at=kept)
                E = 0.5 * (rs @ rs + rd @ rd)
                # the last factorisation models the slightly changed energy: chord steps judge it
                stale = held if quick else None
                last_decrease = math.inf
                yield run.snapshot(E, ev.xyz[rnd.alive], True, kept.length[rnd.spring_on])
                continue
            # a refill that found nothing finds nothing again while no node has left since
            if not (opts.reuse and quiet) and run.try_refill(rnd.surface_at(ev)):
                stale, held, quiet = None, None, False
                rnd, ev, (rs, Q, rd, Jd), E, kept = start()
                yield run.snapshot(E, ev.xyz, True, kept.length)
                continue
            quiet = True
            if not rnd.settled and E > rnd.floor:
                rnd.settled = True  # nothing to refill: now converge tightly
                stale = held if opts.reuse else None
                # the first chord step is judged on its own: the decrease before it was the last, loosely
                # converged step of the round before settling (often tiny), which would end the chord steps
                # at once and cost a factorisation
                last_decrease = math.inf
                continue
            run.status, run.message = 0, "converged"
            return


# ------------------------------------------------------------------ the paper's CG
_GOLD = (math.sqrt(5) - 1) / 2


def _line_search(f, alpha0: float, f0: float, max_eval: int = 60):
    """Minimise f(alpha), alpha > 0, by bracketing then golden-section search.

    Returns (alpha, f(alpha), evaluations). alpha = 0 if no decrease is found.
    """
    evals = 0
    a, fa = 0.0, f0
    b = alpha0
    fb = f(b)
    evals += 1
    while not fb < fa:  # shrink until we go downhill
        b *= 0.1
        fb = f(b)
        evals += 1
        if b < 1e-27 * alpha0 or evals > max_eval // 2:
            return 0.0, f0, evals
    c = b / _GOLD
    fc = f(c)
    evals += 1
    while fc < fb and evals < max_eval:  # expand
        a, fa, b, fb = b, fb, c, fc
        c = b + (b - a) / _GOLD
        fc = f(c)
        evals += 1
    # golden section on [a, c] around b
    lo, hi = a, c
    x1 = hi - _GOLD * (hi - lo)
    x2 = lo + _GOLD * (hi - lo)
    f1, f2 = f(x1), f(x2)
    evals += 2
    while evals < max_eval and (hi - lo) > 1e-6 * max(hi, 1e-300):
        if f1 < f2:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - _GOLD * (hi - lo)
            f1 = f(x1)
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + _GOLD * (hi - lo)
            f2 = f(x2)
        evals += 1
    best = min(((fb, b), (f1, x1), (f2, x2)))
    if best[0] < f0:
        return best[1], best[0], evals
    return 0.0, f0, evals


def iterate_paper(run: Run):
    surface = run.problem.surface
    opts = run.options
    while True:  # one round per population
        mesh = run.mesh
        energy = Energy(surface, mesh, run.terms)
        fixed = _node_at(mesh, run.fixed_ij)
        floor = _energy_floor(mesh)
        pinned = _node_at(mesh, run.pin.ij) if run.pin is not None else None

        def constrain(grad):
            if fixed is not None:
                grad[fixed] = 0.0
            if pinned is not None:
                off = run.pin.off_plane_uv(run.uv[pinned])
                grad[pinned] -= (grad[pinned] @ off) * off
            return grad

        E, g = energy.value_and_grad(run.uv)
        run.nfev += 1
        _check_value_and_grad(surface, run.uv, E, g, run.nit)
        g = constrain(g)
        D = -g  # steepest descent first, and after every change of population
        gg = float(np.sum(g * g))
        dom = surface.domain
        alpha = 1e-3 * float(np.min(dom[:, 1] - dom[:, 0])) / max(float(np.abs(D).max()), 1e-300)
        converged = False
        while not converged:
            if not run.budget_left():
                S = surface.points(run.uv)
                yield run.snapshot(E, S, False)
                return
            if E <= floor or gg == 0.0:
                converged = True
                break
            uv0 = run.uv

            def moved(t):
                uv_t = run.problem.onto_domain(uv0 + t * D)
                if pinned is not None:
                    before = uv_t[pinned].copy()
                    run.pin.retract(uv_t, pinned)
                    if not np.isfinite(uv_t[pinned]).all():
                        raise _not_finite("the (u, v) of the node held to the weft plane", uv_t[pinned],
                                          run.nit + 1, _surface_cause(surface, before)
                                          or "its retraction onto the plane diverged")
                return uv_t

            def f(t):
                uv_t = moved(t)
                S = surface.points(uv_t)
                e = energy.value_xyz(S)
                if not math.isfinite(e) and _broken_inside(surface, uv_t, S):
                    raise _not_finite("the energy", e, run.nit + 1, _cause(surface, uv_t))
                return e

            t, E2, ev = _line_search(f, alpha, E)
            run.nfev += ev
            run.nit += 1
            if t == 0.0:
                if np.array_equal(D, -g):
                    converged = True  # no descent even along the gradient
                    S = surface.points(run.uv)
                    yield run.snapshot(E, S, False)
                    break
                D = -g  # restart
                continue
            alpha = t
            uv_new = moved(t)
            decrease = E - E2
            if run.remove_invalid(uv0, uv_new):
                S = surface.points(run.uv)
                yield run.snapshot(Energy(surface, run.mesh, run.terms).value_xyz(S), S, True)
                break  # new population: restart with steepest descent
            E = E2
            E_check, g_new = energy.value_and_grad(run.uv)
            run.nfev += 1
            _check_value_and_grad(surface, run.uv, E_check, g_new, run.nit)
            g_new = constrain(g_new)
            gg_new = float(np.sum(g_new * g_new))
            beta = gg_new / gg if gg > 0 else 0.0  # Fletcher-Reeves
            D = -g_new + beta * D
            if float(np.sum(D * g_new)) >= 0:  # not a descent direction: restart
                D = -g_new
            g, gg = g_new, gg_new
            S = surface.points(run.uv)
            yield run.snapshot(E, S, False)
            if decrease <= opts.tol * (E + decrease):
                converged = True
        if converged:
            if run.try_refill():
                S = surface.points(run.uv)
                yield run.snapshot(Energy(surface, run.mesh, run.terms).value_xyz(S), S, True)
                continue
            if run.bend():
                S = surface.points(run.uv)
                yield run.snapshot(Energy(surface, run.mesh, run.terms).value_xyz(S), S, True)
                continue
            run.status, run.message = 0, "converged"
            return


def _check_value_and_grad(surface, uv: np.ndarray, E: float, g: np.ndarray, iteration: int) -> None:
    """SolverError unless the energy and its gradient at ``uv`` are finite."""
    if not math.isfinite(E):
        raise _not_finite("the energy", E, iteration, _cause(surface, uv))
    if not np.isfinite(g).all():
        raise _not_finite("the energy's gradient", g, iteration, _cause(surface, uv))


def iterate(problem: Problem, state: State, options: SolverOptions = SolverOptions()):
    """Generator of :class:`Snapshot` s; its return value (``StopIteration.value``)
    is the :class:`SolveResult`. Closing it early stops the solve. A value that
    becomes NaN or infinite raises :class:`~flatweave.errors.SolverError`."""
    run = Run(problem, state, options)
    inner = solver_entry(options.method).run(run)
    try:
        yield from inner
    except GeneratorExit:
        inner.close()
        raise
    # the springs bent where the nodes ended, as a build at this (u, v) bends them: the energy is the
    # one a result file reopens to, the same function for every solver
    ev = problem.surface.evaluate(run.uv)
    run.mesh = bent(run.mesh, ev.xyz, ev.normal)
    S = ev.xyz
    E = Energy(problem.surface, run.mesh, problem.yarns).value_xyz(S)
    if not (math.isfinite(E) and np.isfinite(S).all()):
        raise _not_finite("the energy", E, run.nit, _cause(problem.surface, run.uv))
    return run.result(E)


STOPPED = "stopped by the caller"


def stopped_result(snap: Snapshot, message: str = STOPPED, history=()) -> SolveResult:
    """The solve as it stood at ``snap`` when its caller stopped it (status 3)."""
    return SolveResult(snap.mesh, snap.uv, snap.xyz, snap.energy, snap.iteration, snap.nfev, 3, message,
                       snap.seconds, history=list(history))


def minimize(problem: Problem, state: State, options: SolverOptions = SolverOptions(),
             callback=None) -> SolveResult:
    """Run a solver to the end. ``callback(snapshot)`` is called every
    iteration; returning True (or raising StopIteration) stops the solve
    within that iteration, with status 3."""
    gen = iterate(problem, state, options)
    last = None
    while True:
        try:
            snap = next(gen)
        except StopIteration as done:
            return done.value
        last = snap
        stop = False
        if callback is not None:
            try:
                stop = bool(callback(snap))
            except StopIteration:
                stop = True
        if stop:
            gen.close()
            return stopped_result(last)
