"""A coarse-to-fine start for large pieces: solve the lattice at twice the
spacing, carry its solution to the fine lattice, and start the fine solve there.

A solve from the drape spends most of its iterations moving the whole net
(shear spreads over the piece, nodes slide out on one side and gaps open on
the other, round after round of population control). The coarse lattice
does that at a quarter of the unknowns; its nodes are every second node of
the fine lattice (fine position (2i, 2j) is coarse (i, j): both lattices
start at the seed with the same weft direction), and the fine nodes between
them start at the midpoints of the coarse springs and the centres of the
coarse cells. What the fine solve has left is local.

Only the start changes: the fine problem, its population control and its
stopping rule are the ones a solve from the drape has.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flatweave.geometry.numerics import rowdot, solve2
from flatweave.method.lattice import DIAG, Material, SpringMesh
from flatweave.method.solver import Problem, State

__all__ = ["MIN_NODES", "COARSEST_NODES", "levels_for", "refine", "extend", "stretches", "carry"]

MIN_NODES = 2_000
"""Estimated nodes from which a fast solve starts from a coarser level. Below
it the coarsest level would have fewer than ``COARSEST_NODES`` nodes; from it
a quarter-size solve settles the population for the fine one (or shows that
the drape already holds it, see ``flatweave.method.pipeline._start``)."""

COARSEST_NODES = 500
"""A coarser level is made only while it keeps at least this many nodes: a
coarser net than that no longer follows the piece's outline closely enough
to start the next one (its boundary cells are a large share of it)."""


def levels_for(n_nodes: float) -> int:
    """How many coarser levels a piece of about ``n_nodes`` nodes starts from
    (0: from the drape). Each level has a quarter of the nodes of the next."""
    if n_nodes < MIN_NODES:
        return 0
    k = 0
    while n_nodes / 4 >= COARSEST_NODES:
        n_nodes /= 4
        k += 1
    return k


def stretches(material) -> bool:
    """Whether the refined net's edge is carried on (:func:`extend`) rather than
    refilled at rest length: where the cloth resists shear about as much as
    stretch (isotropic; diagonals at least a tenth as stiff as the threads) the
    solved piece is stretched evenly and the refill's rest-length nodes start
    far from it (the first Newton steps then overshoot and are rejected).
    Woven threads barely stretch, so rest length is where they sit, and lines
    carried straight on in (u, v) leave the curved threads
    (docs/decisions/0043-coarse-to-fine-start.md)."""
    k = material.constants()
    return float(k[2]) >= 0.1 * float(min(k[0], k[1]))


def refine(surface, mesh: SpringMesh, uv: np.ndarray, inside=None) -> tuple[np.ndarray, np.ndarray]:
    """The fine lattice's nodes from a coarse solution: (ij (n, 2), uv (n, 2)),
    sorted by lattice row, then column.

    mesh, uv : the coarse mesh and its nodes' (u, v). A fine node between two
    coarse nodes is made only where the coarse mesh has the spring joining
    them, and one in a cell's centre only where it has the cell: a spring a
    dart cut leaves no node on the dart. A new node is put where the chord's
    midpoint (or the cell's centroid) in space projects onto the surface, by
    one Gauss-Newton step from the (u, v) average (the average alone is off
    the threads' lengths where the parametrisation is uneven, as near a pole).
    ``inside(uv) -> bool`` (a trimmed region) drops the new nodes outside it,
    as do the limits of the (u, v) domain.
    """
    uv = np.asarray(uv, dtype=float)
    ij = mesh.ij.astype(np.int64)
    thread = mesh.kind != DIAG
    a, b = mesh.ends[thread, 0], mesh.ends[thread, 1]
    c = mesh.cells  # corners (i, j), (i, j+1), (i+1, j+1), (i+1, j)
    # a fine node halfway between coarse a and b is at (2 ij_a + 2 ij_b) / 2
    new_ij = [ij[a] + ij[b], 2 * ij[c[:, 0]] + 1]
    xyz = surface.points(uv)
    targets = [0.5 * (xyz[a] + xyz[b]), xyz[c].mean(axis=1)]
    starts = [0.5 * (uv[a] + uv[b]), uv[c].mean(axis=1)]
    nij = np.concatenate(new_ij)
    nuv = np.concatenate(starts)
    target = np.concatenate(targets)
    ev = surface.evaluate(nuv)
    r = target - ev.xyz
    # one Gauss-Newton step of min |S(uv) - target|^2: (J^T J) d = J^T r, J = [S_u S_v]
    g12 = rowdot(ev.su, ev.sv)
    JtJ = np.stack([np.stack([rowdot(ev.su, ev.su), g12], -1), np.stack([g12, rowdot(ev.sv, ev.sv)], -1)], -2)
    d, ok = solve2(JtJ, -np.column_stack([rowdot(ev.su, r), rowdot(ev.sv, r)]))
    d[~ok] = 0.0  # a degenerate frame (a pole) keeps the average
    nuv = nuv + d
    keep = np.isfinite(nuv).all(axis=1)
    keep[keep] = surface.in_domain(nuv[keep])
    if inside is not None and keep.any():
        keep[keep] = inside(nuv[keep])
    all_ij = np.concatenate([2 * ij, nij[keep]])
    all_uv = np.concatenate([uv, nuv[keep]])
    order = np.lexsort((all_ij[:, 1], all_ij[:, 0]))
    return all_ij[order], all_uv[order]


def extend(surface, ij: np.ndarray, uv: np.ndarray, inside=None, separated=None,
           passes: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Nodes added at the empty lattice positions next to the mesh, carried on
    along the lattice lines: a position whose two nodes before it on a weft
    or warp line exist gets 2 uv_1 - uv_0 (the average over the lines that
    reach it), for ``passes`` rings. Returns all nodes (ij, uv), sorted.

    The refined coarse net stops up to a coarse spacing short of the piece's
    edge. The drape's refill would put nodes there at rest length from two
    neighbours, and where the piece is stretched (an isotropic material) that
    strip starts far from the stretched interior around it; carrying the
    lines on keeps their strain. Positions outside the domain or the region
    (``inside``) stay empty, for the refill to judge; ``separated(uv_a, uv_b)
    -> (k,) bool`` (a dart between two points) stops a line at a dart.
    """
    ij = np.asarray(ij, dtype=np.int64)
    uv = np.asarray(uv, dtype=float)
    for _ in range(passes):
        lo = ij.min(axis=0) - 3
        shape = tuple(ij.max(axis=0) - lo + 4)
        grid = np.full(shape, -1, dtype=np.int64)
        grid[ij[:, 0] - lo[0], ij[:, 1] - lo[1]] = np.arange(len(ij))
        acc = np.zeros(shape + (2,))
        cnt = np.zeros(shape)
        for d in ((0, 1), (0, -1), (1, 0), (-1, 0)):
            d = np.array(d)
            p1 = ij - lo  # node 1 (the last on the line) and node 0 before it
            p0 = p1 - d
            tgt = p1 + d
            ok = (p0 >= 0).all(axis=1) & (p0 < shape).all(axis=1)
            ok &= (tgt >= 0).all(axis=1) & (tgt < shape).all(axis=1)
            n0 = np.full(len(ij), -1)
            n0[ok] = grid[p0[ok, 0], p0[ok, 1]]
            ok &= n0 >= 0
            ok[ok] = grid[tgt[ok, 0], tgt[ok, 1]] < 0
            i1 = np.flatnonzero(ok)
            cand = 2 * uv[i1] - uv[n0[i1]]
            if separated is not None and len(i1):
                ok2 = ~np.asarray(separated(uv[i1], cand), dtype=bool)
                i1, cand = i1[ok2], cand[ok2]
            np.add.at(acc, (tgt[i1, 0], tgt[i1, 1]), cand)
            np.add.at(cnt, (tgt[i1, 0], tgt[i1, 1]), 1)
        pos = np.argwhere(cnt > 0)
        if not len(pos):
            break
        new_uv = acc[pos[:, 0], pos[:, 1]] / cnt[pos[:, 0], pos[:, 1], None]
        keep = np.isfinite(new_uv).all(axis=1)
        keep[keep] = surface.in_domain(new_uv[keep])
        if inside is not None and keep.any():
            keep[keep] = inside(new_uv[keep])
        if not keep.any():
            break
        ij = np.concatenate([ij, pos[keep] + lo])
        uv = np.concatenate([uv, new_uv[keep]])
    order = np.lexsort((ij[:, 1], ij[:, 0]))
    return ij[order], uv[order]


def carry(surface, problem: Problem, mesh: SpringMesh, uv: np.ndarray, material: Material,
          inside=None) -> State:
    """The fine solve's start from a coarse solution (mesh, uv): refined
    (:func:`refine`), carried on to the edge where the material stretches
    (:func:`extend`), and refilled by the problem's own refill wherever a
    position is still empty; built by the fine problem (springs across darts cut)."""
    ij, fuv = refine(surface, mesh, uv, inside)
    if stretches(material):
        ij, fuv = extend(surface, ij, fuv, inside, problem.cut)
    # the refill needs the nodes' places and the surface there, not their springs: the mesh is built once,
    # with the nodes it adds (a build is most of a carry's time on a large piece)
    ev = surface.evaluate(fuv)
    placed = _Placed(ij, 0.5 * mesh.r_weft, 0.5 * mesh.r_warp)
    add_ij, add_uv = problem.refill(placed, fuv, np.zeros((0, 2), dtype=np.int64), (ev.xyz, ev.su, ev.sv))
    if len(add_ij):
        ij, fuv = np.concatenate([ij, add_ij]), np.concatenate([fuv, add_uv])
        order = np.lexsort((ij[:, 1], ij[:, 0]))
        ij, fuv = ij[order], fuv[order]
    return State(problem.build(ij, fuv), fuv)


@dataclass(frozen=True)
class _Placed:
    """Nodes placed on the fine lattice before their springs are built: what a refill reads of a mesh."""

    ij: np.ndarray
    r_weft: float
    r_warp: float
