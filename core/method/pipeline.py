"""One path from surface to result, shared by the CLI, the GUI and the tests.

surface -> drape -> minimise -> pattern -> metrics -> result dictionary

:func:`flatten_iter` is the generator the GUI's worker runs (a snapshot per
solver iteration, the :class:`FlattenResult` as its return value);
:func:`flatten` drains it for the CLI and the tests.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np
from scipy.spatial import cKDTree

from flatweave.method import multilevel
from flatweave.geometry.coverage import cell_diagonal, uncovered_share
from flatweave.method.darts import DartSet
from flatweave.method.drape import DrapeResult, DrapeSettings, check_node_count, drape, refill
from flatweave.method.energy import resolve_yarns
from flatweave.geometry.numerics import require_finite
from flatweave.errors import SettingsError, SolverError
from flatweave.files import decode_array
from flatweave.method.lattice import Material, SpringMesh, bent, build_mesh, only_springs
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.method.pattern import Pattern, framed_nodes, make_pattern, resample_uv
from flatweave.geometry.quadrature import boundary_polyline, domain_gauss_rule, region_area
from flatweave.geometry.region import Cover, Region, cover_for
from flatweave.method.solver import STOPPED, Problem, SolveResult, SolverOptions, State, iterate
from flatweave.method.solver import stopped_result as stopped_solve
from flatweave.method.solvers import solver_entry
from flatweave.method.settings import FlattenSettings, SETTINGS_KEYS, settings_to_dict, validate_settings
from flatweave.method.result import (FlattenResult, compute_metrics, coverage_metrics, judge_result, judged,
                                     result_to_dict, with_shear_angles)

__all__ = ["FlattenSettings", "FlattenResult", "flatten", "flatten_iter", "result_to_dict",
           "make_problem", "compute_metrics", "state_from_dict", "check_result_finite",
           "validate_settings", "settings_to_dict", "SETTINGS_KEYS", "stopped_result", "coverage_metrics",
           "judge_result", "judged", "with_shear_angles"]

"""The spring method's solver choices, 'none' (the drape only) included (:mod:`flatweave.method.solvers`)."""


"""The settings' entries in a project file (darts and yarns are listed beside them)."""


EDGE_REFILL_SPACINGS = 0.1
"""A refill every one of whose nodes would land within this share of a spacing of the region's
edge, while every point of the region is within a cell diagonal of a node, is not made: the edge's
churn, not a gap (:func:`edge_churn`). 0 makes every refill (the paper's Node Filling)."""


def edge_churn(cover: Cover, new_uv: np.ndarray, xyz: np.ndarray, r_weft: float, r_warp: float) -> bool:
    """True if a refill adding nodes at ``new_uv`` (k, 2) to a population at ``xyz`` (n, 3) is the
    edge's churn: every new node within :data:`EDGE_REFILL_SPACINGS` of a spacing of the region's
    edge (:meth:`Cover.edge_chord`) and the region covered (``metrics["uncovered_pct"]`` 0).

    After a dart opens, the net slides: a position opens at the edge where a node lands a hair
    inside, a round starts for it, and the slid net lets another node out elsewhere; each such
    round costs a refill, a new pattern and analysis and a few iterations
    (docs/decisions/0045-no-refill-of-edge-nodes-only.md). A refill with a node deeper in, or
    while part of the region is uncovered, is made whole."""
    if EDGE_REFILL_SPACINGS <= 0 or len(new_uv) == 0:
        return False
    if (cover.edge_chord(new_uv) >= EDGE_REFILL_SPACINGS * min(r_weft, r_warp)).any():
        return False
    reach = cell_diagonal(r_weft, r_warp)
    return uncovered_share(cover.surface, xyz, reach, cover.coverage_grid(reach)) == 0.0


def make_problem(surface: NurbsSurface, settings: FlattenSettings) -> Problem:
    """The solver's view of a piece: how a population's springs are built and refilled."""
    ds = settings.drape_settings()
    material = settings.material
    darts = DartSet(surface, settings.darts)
    cover = cover_for(surface, settings.region)
    inside = cover.contains if cover.trimmed else None
    ease = eased_lines(surface, settings)

    def build(ij, uv):
        keep = darts.keep_springs(np.asarray(uv)) if len(darts) else None
        mesh = build_mesh(ij, ds.r_weft, ds.r_warp, material, keep=keep)
        if ease:
            mesh = replace(mesh, ease=ease)
        ev = surface.evaluate(uv)
        return bent(mesh, ev.xyz, ev.normal)

    def refill_nodes(mesh, uv, dead, at=None):
        ij, new = refill(surface, ds, mesh.ij, uv, dead, separated=darts.crossing if len(darts) else None,
                         inside=inside, at=at)
        if len(ij) and edge_churn(cover, new, surface.points(uv) if at is None else at[0], mesh.r_weft, mesh.r_warp):
            return ij[:0], new[:0]
        return ij, new

    # a node whose step would carry it through a dart is deleted (3.3)
    cut = darts.crossing if len(darts) else None
    invalid = cut
    if inside is not None:  # a node that leaves the region is deleted, as one that leaves the domain
        def invalid(uv_old, uv_new, *xyz):
            bad = ~inside(uv_new)
            return bad if cut is None else bad | cut(uv_old, uv_new, *xyz)
    return Problem(surface, build, settings.yarns, refill_nodes, invalid, cut=cut)


EASE_BAND = 2.0
"""A matched seam eases the springs within this many spacings of its sew line (fading to none there)."""


def eased_lines(surface: NurbsSurface, settings: FlattenSettings) -> tuple:
    """The settings' ``ease`` on the surface, as :attr:`flatweave.method.lattice.SpringMesh.ease` takes it:
    each sew line's points about a quarter spacing apart in 3D, its amount, its band."""
    step = min(settings.spacing, settings.spacing_warp or settings.spacing)
    return tuple((surface.points(resample_uv(surface, np.asarray(uv, dtype=float), 0.25 * step)), float(amount),
                  EASE_BAND * step) for uv, amount in settings.ease)


def unease(mesh: SpringMesh, surface: NurbsSurface, uv: np.ndarray) -> SpringMesh:
    """``mesh`` with no ease: its springs at the fabric's own rest lengths, bent at ``uv``; the mesh
    itself when it has none."""
    if not mesh.ease:
        return mesh
    ev = surface.evaluate(uv)
    return bent(replace(mesh, ease=()), ev.xyz, ev.normal)


def drape_piece(surface: NurbsSurface, ds: DrapeSettings, material: Material, cover: Cover,
                **kwargs) -> DrapeResult:
    """:func:`flatweave.method.drape.drape` for a piece: over the whole domain, or, trimmed,
    inside the region's outer loop, its holes and all, and then without the
    nodes in the holes.

    The net is laid as if the holes were not there because one laid round a
    hole is not one net: the fronts that pass either side of it meet behind it
    out of step (each grew from its own neighbours), the drape refuses the
    positions where they meet (too near a node of the other front), and a slit
    with no springs across it is left from the hole to the edge. The solve then
    lets the slit's sides overlap and the pattern opens there like a dart (a
    doubly curved panel with a hole: boundary error 22 % against 1.7 %,
    docs/decisions/0036-holed-region-draped-across-its-holes.md). The surface is there in a hole
    (it spans the domain), so the net can cross it."""
    if not cover.trimmed:
        return drape(surface, ds, material, **kwargs)
    if not cover.region.n_holes:
        return drape(surface, ds, material, inside=cover.contains, **kwargs)
    outer = cover_for(surface, Region.from_loops(cover.region.arrays()[0]))
    d = drape(surface, ds, material, inside=outer.contains, **kwargs)
    keep = cover.contains(d.uv)
    if keep.all():
        return d
    mesh = build_mesh(d.mesh.ij[keep], ds.r_weft, ds.r_warp, material)
    return DrapeResult(mesh=mesh, uv=d.uv[keep], xyz=d.xyz[keep], stats=d.stats)


def _levels(settings: FlattenSettings, area: float) -> int:
    """Coarser levels a solve from the drape starts from (:func:`flatweave.method.multilevel.levels_for`);
    for a solver that declares ``coarse_start`` (the fast one; the paper's scheme is the
    reference it is measured against), and not with darts: near a dart the coarse net's edge
    differs from the fine drape's, and the population the fine solve settles on there with it
    (docs/decisions/0043-coarse-to-fine-start.md)."""
    if not solver_entry(settings.solver).coarse_start or settings.darts:
        return 0
    sw = settings.spacing_warp or settings.spacing
    return multilevel.levels_for(area / (settings.spacing * sw))


def _coarser(settings: FlattenSettings) -> FlattenSettings:
    """The settings one level coarser: twice the spacing; a yarn held by index holds
    the coarse row or column nearest its own (fine row 2i is coarse row i), one
    with a picked point resolves on the coarse lattice as on any other."""
    sw = None if settings.spacing_warp is None else 2 * settings.spacing_warp
    yarns = tuple(y if y.point is not None else replace(y, index=y.index // 2) for y in settings.yarns)
    return replace(settings, spacing=2 * settings.spacing, spacing_warp=sw, yarns=yarns)


def _on_lattice(surface: NurbsSurface, settings: FlattenSettings, mesh: SpringMesh, uv: np.ndarray) -> State:
    """A state on the settings' lattice: a coarser level's (a run stopped during a
    coarse-to-fine start) refined level by level, as the start would have."""
    k = int(round(math.log2(mesh.r_weft / settings.spacing))) if mesh.r_weft > 1.5 * settings.spacing else 0
    if k <= 0:
        return State(mesh, uv)
    cover = cover_for(surface, settings.region)
    inside = cover.contains if cover.trimmed else None
    for level in range(k - 1, -1, -1):
        fine = settings
        for _ in range(level):
            fine = _coarser(fine)
        ij, uv = multilevel.refine(surface, mesh, uv, inside)
        mesh = make_problem(surface, fine).build(ij, uv)
    return State(mesh, uv)


def _solved_before(stats: dict) -> list:
    """The solves before a start's own: a dropped coarse solve (its drape held, see
    :func:`_start`) and each coarser level carried to it, coarsest first."""
    return list(stats.get("dropped", ())) + list(stats.get("levels", ()))


def _coarse_iterations(stats: dict) -> int:
    """The iterations of the solves before a start's own (0 from the drape)."""
    return sum(lv["iterations"] for lv in _solved_before(stats))


def _carried(options: SolverOptions, stats: dict) -> SolverOptions:
    """The solver's options for a level: what is left of the budgets after the solves
    before it (the budgets are the whole run's, not each level's), and a start carried
    from a coarser level (``stats`` has its ``levels``) never refills a position its
    solve emptied (``dead_after`` 1)."""
    before = _solved_before(stats)
    if before:
        spent = sum(lv["solve_seconds"] + lv["refine_seconds"] for lv in before)
        options = replace(options, max_iter=max(0, options.max_iter - _coarse_iterations(stats)),
                          max_seconds=max(0.0, options.max_seconds - spent))
    return replace(options, dead_after=1) if stats.get("levels") else options


def _budget_message(solve: SolveResult, options: SolverOptions) -> str:
    """The solve's status, a budget named as the run's (a level after coarser ones had what was left)."""
    if solve.status == 1:
        return f"stopped at the iteration budget ({options.max_iter})"
    if solve.status == 2:
        return f"stopped at the time budget ({options.max_seconds:g} s)"
    return solve.message


def _counted_from(gen, done: int):
    """``yield from gen`` (a solve), its snapshots' iterations counted on from ``done``
    (the iterations of the coarser levels before it: one count over a coarse-to-fine run)."""
    if not done:
        return (yield from gen)
    try:
        while True:
            try:
                snap = next(gen)
            except StopIteration as end:
                return end.value
            yield replace(snap, iteration=snap.iteration + done)
    finally:
        gen.close()


def _drape_state(surface: NurbsSurface, settings: FlattenSettings, problem: Problem, cover: Cover, A3: float,
                 drape_progress, drape_interval: float):
    """The settings' own lattice draped: its state and the drape's stats."""
    progress = None
    if drape_progress is not None:
        def progress(ij, uv, xyz):
            if len(ij) < 3:
                return
            order = np.lexsort((ij[:, 1], ij[:, 0]))
            drape_progress(problem.build(ij[order], uv[order]), uv[order], xyz[order])
    d = drape_piece(surface, settings.drape_settings(), settings.material, cover, area=A3, progress=progress,
                    progress_interval=drape_interval)
    _check_drape(surface, d, settings.drape_settings(), cover)
    return State(problem.build(d.mesh.ij, d.uv), d.uv), d.stats


def _level_record(coarse: FlattenSettings, solve, refine_seconds: float) -> dict:
    """A coarser solve's entry in a start's stats (``levels`` or ``dropped``)."""
    return {"spacing": coarse.spacing, "nodes": int(solve.mesh.n_nodes), "iterations": int(solve.nit),
            "deleted": int(solve.deleted), "added": int(solve.added), "converged": solve.status == 0,
            "solve_seconds": solve.seconds, "refine_seconds": refine_seconds,
            "history": [float(e) for e in solve.history]}


def _start(surface: NurbsSurface, settings: FlattenSettings, problem: Problem, cover: Cover, A3: float,
           levels: int, drape_progress, drape_interval: float, top: bool = True):
    """Generator: the state a solve from scratch starts from, and the drape's stats
    (with a coarse-to-fine start, each coarser level's in ``stats["levels"]``).

    With ``levels`` > 0 the piece is solved first at twice the spacing (itself
    started ``levels - 1`` levels coarser), yielding that solve's snapshots, and
    its solution carried onto this lattice (:func:`flatweave.method.multilevel.carry`).

    When the coarsest level's solve from its own drape converges and neither
    deletes nor refills a node, the drape held: the nodes the drape placed are
    the ones the minimum keeps, and the settings' own lattice is draped instead
    of carried (a carried net only approaches what the fine drape reaches from
    where the threads lie). That solve is kept in ``stats["dropped"]`` (its
    snapshots were shown and its iterations are counted on); a level below the
    top returns ``(None, stats)`` for the top to drape."""
    # the fine lattice is never draped on a coarse-to-fine start: its size is checked here, before any level
    check_node_count(settings.drape_settings(), A3)
    if levels <= 0:
        return _drape_state(surface, settings, problem, cover, A3, drape_progress, drape_interval)
    coarse = _coarser(settings)
    cproblem = make_problem(surface, coarse)
    state, stats = yield from _start(surface, coarse, cproblem, cover, A3, levels - 1, drape_progress,
                                     drape_interval, top=False)
    if state is not None:
        if coarse.yarns:
            cproblem.yarns = resolve_yarns(coarse.yarns, state.mesh, surface.points(state.uv))
        done = _coarse_iterations(stats)
        options = coarse.solver_options()
        options = replace(options, tol=max(options.tol, COARSE_TOL))
        solve = yield from _counted_from(iterate(cproblem, state, _carried(options, stats)), done)
        if "levels" in stats or solve.status != 0 or solve.deleted or solve.added:
            t = time.perf_counter()
            fine = multilevel.carry(surface, problem, solve.mesh, solve.uv, settings.material,
                                    cover.contains if cover.trimmed else None)
            record = _level_record(coarse, solve, time.perf_counter() - t)
            return fine, {**stats, "levels": list(stats.get("levels", ())) + [record]}
        stats = {**stats, "dropped": [_level_record(coarse, solve, 0.0)]}  # the drape held (see above)
    if not top:
        return None, stats
    state, own = _drape_state(surface, settings, problem, cover, A3, drape_progress, drape_interval)
    # the drape time is both drapes'
    return state, {**own, "dropped": stats["dropped"], "seconds": own.get("seconds", 0.0) + stats.get("seconds", 0.0)}


COARSE_TOL = 1e-6
"""The tolerance a coarser level of a coarse-to-fine start is solved to (at least the settings'):
its solution is only the next level's start. Against the settings' 1e-9 on every bundled example,
woven and isotropic, at 2,500 and 10,000 nodes: the same nodes, errors and energy (to 6e-13), 16 %
less time over them all, 9.9 -> 9.3 s at 160,000 nodes (tests/test_multilevel.py)."""


UNCOVERED_LIMIT = 0.10
"""Largest share of the surface's area a new drape may leave farther than two
spacings from every node. A complete drape leaves none (every point is within
a cell diagonal of a node); on the bundled examples, seeds and angles tried,
at most 2.1 % (corners a helical thread cannot reach); where the threads stop
at a cusp or a pinch, 29 % and more."""


def _check_area(surface: NurbsSurface, area: float) -> None:
    """SettingsError unless the surface has an area the mesh can cover."""
    size = surface.bbox_diagonal()
    if not (math.isfinite(area) and area > 1e-12 * size * size):
        raise SettingsError(f"the surface has no usable area (area {area:.3g} for a control net {size:.3g} "
                            f"across): it is a curve or a point, not a sheet")


MIN_SPACING_SHARE = 1e-6  # a spacing below this share of the piece's size is a slip of the units


def _check_spacing(settings: FlattenSettings, area: float) -> None:
    """SettingsError unless both spacings are at least :data:`MIN_SPACING_SHARE` of the piece's size
    (the square root of its area): a smaller one would need more nodes than any memory holds."""
    size = math.sqrt(area)
    least = min(settings.spacing, settings.spacing_warp or settings.spacing)
    if least < MIN_SPACING_SHARE * size:
        raise SettingsError(f"the spacing {least:g} is below a millionth of the piece's size (about {size:.4g}, "
                            f"the square root of its area): give one from {MIN_SPACING_SHARE * size:.3g}")


def _uncovered_share(surface: NurbsSurface, xyz: np.ndarray, reach: float, inside=None) -> float:
    """Share of the surface's area farther than ``reach`` from every point of ``xyz``
    (Gauss points of the domain, at most ~200,000 of them, weighted by area)."""
    nu, nv = surface.shape
    cells = max(1, (nu - surface.degree_u) * (nv - surface.degree_v))
    uv, w = domain_gauss_rule(surface, int(np.clip(np.sqrt(200_000 / cells), 1, 8)))
    S, su, sv = surface.derivatives(uv)
    a = w * np.linalg.norm(np.cross(su, sv), axis=1)
    if inside is not None:  # a trimmed region: only its part of the domain
        a = np.where(inside(uv), a, 0.0)
    far = cKDTree(xyz).query(S, distance_upper_bound=reach)[0] > reach
    return float(a[far].sum() / a.sum())


def _check_drape(surface: NurbsSurface, d, ds: DrapeSettings, cover: Cover | None = None) -> None:
    """SettingsError unless a new drape can give a pattern of the whole surface (or region)."""
    r = max(ds.r_weft, ds.r_warp)
    trimmed = cover is not None and cover.trimmed
    seed = f"({ds.seed[0]:g}, {ds.seed[1]:g})"
    if not framed_nodes(d.mesh).any():
        n = d.mesh.n_nodes
        placed = f"the drape placed {n:,} node{'s' if n != 1 else ''} but no complete cell of the mesh"
        if trimmed:
            outer, holes = cover.boundary_samples(cover.boundary_length / 4096, 1, 16)
            edge = cKDTree(np.vstack([outer[1]] + [h[1] for h in holes]))
        else:
            edge = cKDTree(boundary_polyline(surface, 1024)[1])
        g = np.linspace(0.0, 1.0, 33)
        dom = surface.domain
        grid = np.column_stack([a.ravel() for a in np.meshgrid(*(lo + g * (hi - lo) for lo, hi in dom))])
        if trimmed:
            inside = cover.contains(grid)
            grid = grid[inside] if inside.any() else cover.seed_uv(cover.default_seed)[None]
        inner = float(edge.query(surface.points(grid))[0].max())  # how far the surface reaches from its edge
        if inner < r:
            raise SettingsError(
                f"{placed}: spacing {r:g} is too large for this surface (no point of it is more than "
                f"{inner:.3g} from its edge); use a spacing below about {inner:.2g}")
        i0 = int(np.flatnonzero((d.mesh.ij == 0).all(axis=1))[0])
        dist = float(edge.query(d.xyz[i0])[0])
        raise SettingsError(
            f"{placed}: from the seed {seed}, {dist:.3g} from the surface's edge, the threads leave the "
            f"surface (or stop) within a spacing; move the seed inward, away from poles, corners and edges")
    share = _uncovered_share(surface, d.xyz, 2 * r, cover.contains if trimmed else None)
    if share > UNCOVERED_LIMIT:
        raise SettingsError(
            f"the drape from seed {seed} covers only {100 * (1 - share):.0f} % of the surface "
            f"({100 * share:.0f} % of its area is over two spacings from every node): the threads stop "
            f"at a cusp, pinch or fold they cannot cross, or a neck narrower than the spacing; split "
            f"the surface there, or try another seed or a smaller spacing")


def _check_finite(what: str, arr, unit: str) -> None:
    """SolverError unless every row of ``arr`` is finite."""
    require_finite(f"the result's {what}", arr, unit)


def check_result_finite(uv: np.ndarray, xyz: np.ndarray, pattern: Pattern | None = None,
                        metrics: dict | None = None) -> None:
    """SolverError unless a result's nodes, pattern and numeric metrics are all
    finite: a result is never made from NaN or infinite numbers."""
    _check_finite("(u, v)", uv, "nodes")
    _check_finite("points on the surface", xyz, "nodes")
    if pattern is not None:
        _check_finite("pattern positions", pattern.xy, "nodes")
        _check_finite("outline", pattern.outline, "outline points")
        for k, piece in enumerate(pattern.pieces):
            _check_finite(f"outline of piece {k + 1}", piece.outline, "outline points")
    if metrics is not None:
        bad = sorted(k for k, v in metrics.items() if isinstance(v, (float, np.floating)) and not math.isfinite(v))
        if bad:
            raise SolverError(f"the result's {', '.join(bad)} {'is' if len(bad) == 1 else 'are'} not finite; "
                              f"the solve stopped and nothing was changed")


def flatten_iter(surface: NurbsSurface, settings: FlattenSettings, initial: State | None = None,
                 area: float | None = None, drape_progress=None, drape_interval: float = 0.2,
                 multilevel: int | None = None):
    """Generator: drape (or warm-start from ``initial``), minimise, pattern.

    Yields the solver's :class:`flatweave.method.solver.Snapshot` s; returns the
    :class:`FlattenResult`. Closing it stops the solve at once.
    A yarn with a picked point (:class:`~flatweave.method.energy.YarnConstraint`) is
    resolved on the drape's (or the warm start's) lattice: the result's
    settings hold it with the index it resolved to.
    ``drape_progress(mesh, uv, xyz)``, if given, sees the mesh laid so far
    during the drape, at most every ``drape_interval`` seconds, built as the solver will build it
    (springs across darts cut); an exception it raises ends the drape. A NaN or
    infinity anywhere (solver, nodes, pattern, metrics) raises
    :class:`~flatweave.errors.SolverError`: no result holds a non-finite number.
    Without ``initial``, a large piece starts from coarser levels (:mod:`flatweave.method.multilevel`;
    ``multilevel``: how many, None to choose by size, 0 for the drape): their
    solves' snapshots come first, each level's mesh its own.
    """
    t0 = time.perf_counter()
    cover = cover_for(surface, settings.region)
    A3 = (cover.area if cover.trimmed else region_area(surface)) if area is None else area
    _check_area(surface, A3)
    _check_spacing(settings, A3)
    if not solver_entry(settings.solver).warm_start:
        initial = None  # the solver declares it starts from a drape only
    if cover.trimmed and initial is None and not cover.contains(cover.seed_uv(settings.seed)[None])[0]:
        ds_ = cover.default_seed
        raise SettingsError(f"the seed ({settings.seed[0]:g}, {settings.seed[1]:g}) lies outside the piece's region; "
                            f"use a seed inside it, e.g. {ds_[0]:.4g},{ds_[1]:.4g} (its point farthest from the edge)")
    problem = make_problem(surface, settings)
    if initial is None:
        levels = _levels(settings, A3) if multilevel is None else int(multilevel)
        state, stats = yield from _start(surface, settings, problem, cover, A3, levels, drape_progress,
                                         drape_interval)
    else:
        uv = np.asarray(initial.uv, dtype=float)
        mesh = problem.build(initial.mesh.ij, uv)
        if not solver_entry(settings.solver).iterative:
            # not solved again: the springs stay the ones solved (a build can add one a dart cut earlier)
            mesh = only_springs(mesh, initial.mesh.ends)
        state, stats = State(mesh, uv), {"warm_start": True, "seconds": 0.0}
    if any(y.point is not None for y in settings.yarns):
        # a picked yarn is the thread through its point on this lattice (after every drape and warm start)
        yarns = resolve_yarns(settings.yarns, state.mesh, surface.points(state.uv))
        if yarns != settings.yarns:
            settings = replace(settings, yarns=yarns)
        problem.yarns = yarns
    solve = None
    if solver_entry(settings.solver).iterative:
        solve = yield from _counted_from(iterate(problem, state, _carried(settings.solver_options(), stats)),
                                         _coarse_iterations(stats))
        state = State(solve.mesh, solve.uv)  # its springs bent where the nodes ended (iterate)
    # the result is judged and kept with the fabric's own springs: a matched seam's ease is how it was solved
    state = State(unease(state.mesh, surface, state.uv), state.uv)
    xyz = surface.points(state.uv)
    check_result_finite(state.uv, xyz)
    if not framed_nodes(state.mesh).any():
        raise SettingsError(f"no complete cell of the mesh is left ({state.mesh.n_nodes:,} nodes): there is "
                            f"nothing to make a pattern from; try a smaller spacing or another seed")
    darts = DartSet(surface, settings.darts)
    if cover.trimmed:  # the outline along the outer loop, the holes along the inner ones
        outer, holes = cover.boundary_samples(min(state.mesh.r_weft, state.mesh.r_warp))
        pattern = make_pattern(surface, state.mesh, xyz, samples=outer, darts=darts if len(darts) else None,
                               uv=state.uv, hole_samples=holes, cover=cover)
    else:
        pattern = make_pattern(surface, state.mesh, xyz, darts=darts if len(darts) else None, uv=state.uv)
    metrics = compute_metrics(surface, state.mesh, xyz, pattern, settings.yarns, A3=A3, cover=cover)
    metrics.update({
        # every level's: the snapshots count on over a coarse-to-fine run, and a stopped one's count is theirs
        "iterations": (solve.nit if solve else 0) + _coarse_iterations(stats),
        "energy_evaluations": solve.nfev if solve else 0,
        "solver_status": _budget_message(solve, settings.solver_options()) if solve else "no solver",
        "nodes_deleted": solve.deleted if solve else 0,
        "nodes_refilled": solve.added if solve else 0,
        # of the nodes the solve started with
        "nodes_deleted_pct": (100.0 * solve.deleted / max(state.mesh.n_nodes + solve.deleted - solve.added, 1)
                              if solve else 0.0),
        "drape_seconds": stats.get("seconds", 0.0),
        # a coarse-to-fine start's coarser solves are part of the solve
        "solve_seconds": (solve.seconds if solve else 0.0) + sum(
            lv["solve_seconds"] + lv["refine_seconds"] for lv in _solved_before(stats)),
        "coarse_levels": len(stats.get("levels", ())),
        "coarse_iterations": _coarse_iterations(stats),
        "seconds": time.perf_counter() - t0,
        "pieces": len(pattern.pieces),
        "unmapped_points": pattern.unmapped,
    })
    if getattr(surface, "fit", None) is not None:  # a surface fitted to a mesh (flatweave.geometry.meshfit)
        metrics.update(surface.fit.metrics())
    check_result_finite(state.uv, xyz, pattern, metrics)
    history = tuple(float(e) for lv in _solved_before(stats) for e in lv.pop("history"))
    if solve:
        history = _ended(history + tuple(solve.history), metrics["energy"])
    result = FlattenResult(surface, settings, state.mesh, state.uv, xyz, pattern, metrics, stats, solve, history)
    return judged(result)


def flatten(surface: NurbsSurface, settings: FlattenSettings, initial: State | None = None,
            area: float | None = None, callback=None, multilevel: int | None = None) -> FlattenResult:
    """Run :func:`flatten_iter` to the end. ``callback(snapshot)`` is called
    at every solver iteration; returning True stops the solve there (the
    result is then the last iterate, with its pattern and metrics, see
    :func:`stopped_result`)."""
    t0 = time.perf_counter()
    gen = flatten_iter(surface, settings, initial, area, multilevel=multilevel)
    history = []
    while True:
        try:
            snap = next(gen)
        except StopIteration as done:
            return done.value
        history.append(snap.energy)
        if callback is not None and callback(snap):
            gen.close()
            return stopped_result(surface, settings, snap, area, history=history, seconds=time.perf_counter() - t0)


def stopped_result(surface: NurbsSurface, settings: FlattenSettings, snap, area: float | None = None,
                   message: str = STOPPED, history=(), seconds: float | None = None) -> FlattenResult:
    """The last iterate of a solve stopped at snapshot ``snap`` as a result.

    Its pattern and metrics are made by the pipeline from the snapshot's
    state (the solver off); the settings are the run's and the solve is
    the one that ran as far as it went (:func:`flatweave.method.solver.stopped_result`):
    its solver, iterations, energy evaluations, ``message`` as status and
    ``history`` (the energy after each iteration) as the energy trace.
    ``seconds``: the run's time from its start to the stop (``metrics["seconds"]``;
    None: the time this function takes, all that is known of the run then).
    """
    t0 = time.perf_counter()
    gen = flatten_iter(surface, replace(settings, solver="none"), _on_lattice(surface, settings, snap.mesh, snap.uv),
                       area)
    try:
        next(gen)
    except StopIteration as done:
        result: FlattenResult = done.value
    else:  # pragma: no cover - the pipeline does not yield without a solver
        raise AssertionError("flatten_iter yielded with the solver off")
    solve = stopped_solve(snap, message, history)
    metrics = dict(result.metrics)
    metrics.update({"iterations": solve.nit, "energy_evaluations": solve.nfev, "solver_status": solve.message,
                    "solve_seconds": solve.seconds,
                    "seconds": time.perf_counter() - t0 if seconds is None else float(seconds)})
    return judged(replace(result, settings=settings, metrics=metrics, solve=solve,
                          history=_ended(history, metrics["energy"])))


def _ended(history, energy: float) -> tuple[float, ...]:
    """A solve's energy trace ending at the result's energy: the last iterate's with the
    springs bent where its nodes are, one more entry where that differs from the last
    (none where the trace is empty: the solve converged at its start)."""
    history = tuple(float(e) for e in history)
    return history if not history or history[-1] == energy else history + (float(energy),)


def state_from_dict(d: dict, surface: NurbsSurface, settings: FlattenSettings) -> State:
    """The mesh state stored in a result file (for a warm start)."""
    if isinstance(d, dict) and d.get("format") == "flatweave-panels":
        raise SettingsError("the warm-start file holds panels (flatten --seam), not one result: a warm start "
                            "takes one piece's result file")
    try:
        what = "the warm-start file's nodes."
        ij = decode_array(d["nodes"]["ij"], what + "ij", SettingsError).astype(float).reshape(-1, 2)
        uv = decode_array(d["nodes"]["uv"], what + "uv", SettingsError).astype(float).reshape(-1, 2)
    except (KeyError, TypeError, ValueError, OverflowError):
        raise SettingsError("the warm-start file has no nodes.ij and nodes.uv") from None
    if not (np.isfinite(ij).all() and (np.abs(ij) < 2.0 ** 52).all() and (ij == np.round(ij)).all()):
        raise SettingsError("the warm-start file's nodes.ij must be whole lattice indices")
    ij = ij.astype(np.int64)
    if len(ij) != len(uv) or len(ij) == 0:
        raise SettingsError("the warm-start file's nodes.ij and nodes.uv differ in length or are empty")
    span = int((ij.max(axis=0) - ij.min(axis=0)).max()) + 1  # rows or columns the nodes reach over
    if span > len(ij):  # a lattice of n connected nodes reaches over at most n rows or columns
        raise SettingsError(f"the warm-start file's nodes.ij reach over {span:,} lattice rows or columns with "
                            f"{len(ij):,} nodes: they are not one lattice")
    if not np.isfinite(uv).all():
        raise SettingsError("the warm-start file's nodes.uv must be finite numbers")
    if not surface.in_domain(uv).all():
        raise SettingsError("the warm-start file's nodes lie outside this surface's domain")
    mesh = make_problem(surface, settings).build(ij, uv)
    ends = d.get("springs", {}).get("ends") if isinstance(d.get("springs"), dict) else None
    if ends is not None:  # the solved springs, which a build at the same (u, v) may exceed by one a dart cut
        try:
            ends = decode_array(ends, "the warm-start file's springs.ends", SettingsError)
            if not (np.isfinite(ends).all() and (ends == np.round(ends)).all()):
                raise ValueError("not whole")
            ends = ends.astype(np.int64).reshape(-1, 2)
        except (TypeError, ValueError):
            raise SettingsError("the warm-start file's springs.ends must be pairs of node indices") from None
        mesh = only_springs(mesh, ends)
    return State(mesh, uv)


