"""Suggested darts: propose curve darts that make a piece's pattern better
where the designer sees it, its metrics against their limits.

A dart opens from the piece's edge inwards, where the cloth is most strained.
:func:`suggest_darts` looks for them one at a time on a converged result:

0. **Need.** A piece whose every metric is within its warning limit
   (:func:`flatweave.method.metrics.metric_limits`; the mesh fit's deviation and the
   deleted nodes aside, :data:`NOT_THE_PATTERNS`) needs no dart: none is tried.
1. **Sites.** Every spring's energy is gathered onto the outer loop's samples
   (the springs within a reach of a sample, a tenth of the piece's size); the
   samples with the most, at least two reaches apart, are the sites.
2. **Candidates.** From each site a straight (u, v) line runs towards the
   piece's deepest point (the default seed: the cloth closes towards the
   middle of the piece), cut at a few fractions of the way there.
3. **Re-solve.** Each candidate is added to the piece's darts and solved from
   the current nodes (a warm start, as after a dart drawn in the window), in
   worker processes.
4. **Vet.** A candidate whose solve did not converge, or that takes any
   metric past a limit (warning or bad) it was within, is dropped; so is one
   that lowers the energy by less than ``min_gain`` of it and leaves as many
   metrics past their limits.
5. **Rank** (:func:`rank_key`): fewest metrics past their bad limit (a usable
   pattern first), then fewest past their warning limit, then one that lowers
   both the boundary and the area error, then the lowest energy. A shorter
   candidate at the winner's site wins instead when it ranks alike and gives
   at least ``short_share`` of the winner's fall in energy (as short as does
   the job).
6. Stop after ``count`` darts, or when no candidate is left; the next dart
   is looked for on the piece with the darts accepted so far.

Each :class:`Proposal` carries its dart (an ordinary :class:`CurveDart`
marked ``auto``) and the metrics after its re-solve; the list
(:class:`Suggestions`) says why it is shorter than asked for.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from flatweave.method.darts import CurveDart
from flatweave.errors import SettingsError
from flatweave.method.metrics import metric_limits
from flatweave.geometry.region import cover_for
from flatweave.method.energy import Energy
from flatweave.errors import FlatweaveError
from flatweave.method.pipeline import flatten
from flatweave.studies.sweep import Runner

__all__ = ["Proposal", "Suggestions", "dart_sites", "candidate_darts", "metric_levels", "rank_key", "suggest_darts",
           "LENGTHS", "NO_DART_NEEDED"]

LENGTHS = (0.5, 0.7, 0.9)
"""A candidate's length, as fractions of the way from its site to the piece's deepest point."""

METRIC_KEYS = ("energy", "boundary_error_pct", "area_error_pct", "max_shear_deg", "area_beyond_lock_pct",
               "max_thread_strain_pct", "uncovered_pct", "nodes", "iterations", "solver_status")

NO_DART_NEEDED = "every metric is within its warning limits"
"""The start of :attr:`Suggestions.reason` when the piece needs no (further) dart."""

NOT_THE_PATTERNS = ("fit_max_deviation_pct", "nodes_deleted_pct")
"""Metrics that do not say a piece needs a dart: the surface fitted to a mesh is the same
whatever is cut, and deleted nodes are a note on the solve (the coverage and the outline's
errors say whether the pattern suffered)."""


@dataclass(frozen=True)
class Proposal:
    """A suggested dart and what it achieves after a re-solve."""

    dart: CurveDart
    metrics: dict
    energy_before: float
    result: object = None  # the re-solved FlattenResult (kept in this process only)

    @property
    def gain(self) -> float:
        """The fall in energy as a share of the energy before."""
        return (self.energy_before - self.metrics["energy"]) / self.energy_before if self.energy_before > 0 else 0.0

    def to_dict(self) -> dict:
        d = {"dart": self.dart.to_dict(), "energy_before": self.energy_before, "gain": self.gain,
             "metrics": {k: self.metrics[k] for k in METRIC_KEYS if k in self.metrics}}
        if self.result is not None:
            d["status"] = self.result.status
        return d


class Suggestions(list):
    """The :class:`Proposal` s of :func:`suggest_darts`, in the order they
    were found (each re-solved with those before it); ``reason``: one line
    saying why there are fewer than were asked for ("" when there are as many)."""

    def __init__(self, proposals=(), reason: str = ""):
        super().__init__(proposals)
        self.reason = reason


def _value(metrics: dict, key: str) -> float | None:
    v = metrics.get(key)
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) else None


def metric_levels(metrics: dict, limits: dict[str, tuple[float, float]]) -> dict[str, int]:
    """Per key of ``limits`` (:func:`flatweave.method.metrics.metric_limits`): 0 when the
    metric is within its warning limit (or not measured), 1 past it, 2 past
    its bad limit, the thresholds as :func:`flatweave.method.metrics.judge` reads them."""
    out = {}
    for key, (warn, bad) in limits.items():
        v = _value(metrics, key)
        out[key] = 0 if v is None else int(v > warn) + int(v > bad)
    return out


def _converged(metrics: dict) -> bool:
    return not str(metrics.get("solver_status", "")).startswith("stopped")


def rank_key(metrics: dict, levels: dict[str, int], before: dict) -> tuple:
    """How a re-solved candidate ranks, smaller first: metrics past their bad
    limit (none: a usable pattern), metrics past their warning limit, 0 when
    neither the boundary nor the area error is above ``before``'s (else 1),
    then the energy."""
    worse_outline = not (metrics["boundary_error_pct"] <= before["boundary_error_pct"]
                         and metrics["area_error_pct"] <= before["area_error_pct"])
    return (sum(v == 2 for v in levels.values()), sum(v >= 1 for v in levels.values()), int(worse_outline),
            float(metrics["energy"]))


def dart_sites(result, count: int = 4) -> np.ndarray:
    """(k, 2) (u, v) of up to ``count`` points of the outer loop with the most
    spring energy near them, at least two reaches apart."""

    surface, settings = result.surface, result.settings
    cover = cover_for(surface, settings.region)
    (uv_b, xyz_b), _ = cover.boundary_samples(settings.spacing)
    e = Energy(surface, result.mesh).spring_energy(result.xyz)
    mid = 0.5 * (result.xyz[result.mesh.ends[:, 0]] + result.xyz[result.mesh.ends[:, 1]])
    size = float(np.linalg.norm(np.ptp(result.xyz, axis=0)))
    reach = 0.1 * size
    tree = cKDTree(mid)
    near = tree.query_ball_point(xyz_b, reach)
    load = np.array([e[idx].sum() if idx else 0.0 for idx in near])
    chosen: list[int] = []
    for k in np.argsort(-load):
        if load[k] <= 0 or len(chosen) >= count:
            break
        if all(np.linalg.norm(xyz_b[k] - xyz_b[j]) >= 2 * reach for j in chosen):
            chosen.append(int(k))
    return uv_b[chosen]


def candidate_darts(result, sites: np.ndarray, lengths=LENGTHS, points: int = 24) -> list[tuple[int, CurveDart]]:
    """(site index, dart) pairs: from each site towards the deepest point."""
    surface, settings = result.surface, result.settings
    cover = cover_for(surface, settings.region)
    deep = cover.seed_uv(cover.default_seed)
    out = []
    for s, p in enumerate(np.asarray(sites, dtype=float)):
        for f in lengths:
            t = np.linspace(0.0, f, points)[:, None]
            uv = p + t * (deep - p)
            out.append((s, CurveDart(uv, name="suggested dart")))
    return out


def _solve(job):
    surface, settings, state = job

    try:
        return flatten(surface, settings, initial=state)
    except FlatweaveError as exc:
        return str(exc)


# An energy this share of sum k r^2 / 2 or less is noise (decision 0057).
ENERGY_NOISE = 1e-12


def suggest_darts(result, count: int = 1, sites: int = 4, lengths=LENGTHS, min_gain: float = 0.03,
                  short_share: float = 0.95, workers: int | None = None, progress=None,
                  limits: dict[str, tuple[float, float]] | None = None) -> Suggestions:
    """Up to ``count`` darts, each the best of its round (module docstring),
    each :class:`Proposal` re-solved with the darts before it; none for a
    piece whose every metric is within its warning limit. The
    :class:`Suggestions`' ``reason`` says why there are fewer than ``count``.

    limits : the (warning, bad) thresholds per metric key the piece and the
        candidates are judged by (None: :func:`flatweave.method.metrics.metric_limits`
        of the result's material and its piece's curvature, as its status)."""
    import os

    if not (isinstance(count, int) and count >= 1):
        raise SettingsError(f"the number of suggested darts must be 1 or more, got {count!r}")
    if result.mesh.n_nodes < 16:
        raise SettingsError("the piece has too few nodes to suggest darts: use a smaller spacing")
    if workers is None:
        workers = max(1, min(os.cpu_count() or 1, 4))
    if limits is None:
        limits = metric_limits(result.settings.material, total_curvature=result.metrics.get("total_curvature"))
    proposals: list[Proposal] = []
    reason = ""
    current = result
    runner = Runner(workers)
    try:
        for k in range(count):
            m0 = current.metrics
            levels0 = metric_levels(m0, limits)
            if not any(v for key, v in levels0.items() if key not in NOT_THE_PATTERNS):
                reason = _no_need(k, [key for key in NOT_THE_PATTERNS if levels0.get(key)])
                break
            cands = candidate_darts(current, dart_sites(current, sites), lengths)
            if not cands:
                reason = "no point of the piece's edge gathers strain energy: no dart to try"
                break
            cands = [(s, replace(d, name=f"suggested dart {len(current.settings.darts) + 1}", auto=True))
                     for s, d in cands]
            jobs = [(current.surface, replace(current.settings, darts=current.settings.darts + (d,)),
                     current.state()) for _, d in cands]
            solved = runner.map(jobs, _solve)
            if progress is not None:
                progress(k + 1, count)
            e0 = float(m0["energy"])
            # an energy within ENERGY_NOISE of the springs' scale is at rest (round-off, the bent springs'
            # precision): a fall below that is no gain (a developable piece: EN 2e-11, darts move it 1 %)
            noise = ENERGY_NOISE * 0.5 * float(np.dot(current.mesh.k, current.mesh.rest ** 2))
            past0 = rank_key(m0, levels0, m0)[:2]
            ok, dropped, crossed = [], {"crossed": 0, "stopped": 0, "failed": 0, "weak": 0}, Counter()
            for (s, d), r in zip(cands, solved):
                if isinstance(r, str):
                    dropped["failed"] += 1
                    continue
                if not _converged(r.metrics):
                    dropped["stopped"] += 1
                    continue
                levels = metric_levels(r.metrics, limits)
                worse = [key for key, v in levels.items() if v > levels0[key]]
                if worse:
                    dropped["crossed"] += 1
                    crossed.update(worse)
                else:
                    rank = rank_key(r.metrics, levels, m0)
                    # no metric nearer its limits and hardly less strain: not worth a cut
                    if rank[:2] == past0 and e0 - r.metrics["energy"] < min_gain * e0 + noise:
                        dropped["weak"] += 1
                    else:  # a worker's result holds a copy of the surface: give it back the caller's own
                        ok.append((s, d, replace(r, surface=current.surface), rank))
            if not ok:
                reason = _none_helps(k, len(cands), dropped, crossed, min_gain)
                break
            best = min(ok, key=lambda c: c[3])
            # the shortest at the best site that ranks alike and does most of the job
            gain = e0 - best[2].metrics["energy"]
            for c in ok:  # candidates are listed shortest first per site
                if c[0] == best[0] and c[3][:3] == best[3][:3] and e0 - c[2].metrics["energy"] >= short_share * gain:
                    best = c
                    break
            proposals.append(Proposal(best[1], dict(best[2].metrics), e0, best[2]))
            current = best[2]
    finally:
        runner.close()
    return Suggestions(proposals, reason)


_METRIC_WORDS = {"uncovered_pct": "uncovered area", "max_thread_strain_pct": "thread strain",
                 "max_shear_deg": "shear", "area_beyond_lock_pct": "area beyond the lock angle",
                 "boundary_error_pct": "boundary error", "area_error_pct": "area error",
                 "nodes_deleted_pct": "nodes deleted", "fit_max_deviation_pct": "the fitted surface's deviation"}


def _no_need(k: int, past: list[str]) -> str:
    what = NO_DART_NEEDED if not past else NO_DART_NEEDED.replace("every metric", "every metric a dart can change")
    why = f" with {k} suggested dart{'s' if k > 1 else ''}: no further dart needed" if k else ": no dart needed"
    words = ", ".join(_METRIC_WORDS[key] for key in past)
    return what + why + (f" ({words} past {'its' if len(past) == 1 else 'their'} own)" if past else "")


def _none_helps(k: int, tried: int, dropped: dict, crossed: Counter, min_gain: float) -> str:
    which = ", ".join(f"{_METRIC_WORDS.get(key, key)} {n}" for key, n in crossed.most_common())
    words = {"crossed": f"took a metric past a limit it was within ({which})", "stopped": "did not converge",
             "failed": "failed to solve",
             "weak": f"lowered the energy by less than {100 * min_gain:g} % and brought no metric within a limit"}
    parts = [f"{n} {words[key]}" for key, n in dropped.items() if n]
    return f"no {'further ' if k else ''}dart tried helps: of {tried} tried, " + ", ".join(parts)
