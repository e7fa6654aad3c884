"""Suggested darts: propose curve darts that most lower a converged piece's strain.

A dart opens from the piece's edge inwards, where the cloth is most strained.
:func:`suggest_darts` looks for them one at a time on a converged result:

1. **Sites.** Every spring's energy is gathered onto the outer loop's samples
   (the springs within a reach of a sample, a tenth of the piece's size); the
   samples with the most, at least two reaches apart, are the sites.
2. **Candidates.** From each site a straight (u, v) line runs towards the
   piece's deepest point (the default seed: the cloth closes towards the
   middle of the piece), cut at a few fractions of the way there.
3. **Re-solve.** Each candidate is added to the piece's darts and solved from
   the current nodes (a warm start, as after a dart drawn in the window), in
   worker processes. Of the candidates that lower both the boundary and the
   area error (all of them if none does), the one with the lowest energy wins; a shorter one
   at the same site wins instead when it gives at least ``short_share`` of
   the longest's fall in energy (as short as does the job).
4. Stop when the best lowers the energy by less than ``min_gain`` of it, or
   after ``count`` darts. The next dart is looked for on the piece with the
   darts accepted so far.

Each :class:`Proposal` carries its dart (an ordinary :class:`CurveDart`
marked ``auto``) and the metrics after its re-solve.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from core.darts import CurveDart
from core.errors import SettingsError
from core.region import cover_for

__all__ = ["Proposal", "dart_sites", "candidate_darts", "suggest_darts", "LENGTHS"]

LENGTHS = (0.5, 0.7, 0.9)
"""A candidate's length, as fractions of the way from its site to the piece's deepest point."""

METRIC_KEYS = ("energy", "boundary_error_pct", "area_error_pct", "max_shear_deg", "area_beyond_lock_pct",
               "max_thread_strain_pct", "nodes", "iterations")


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
        return {"dart": self.dart.to_dict(), "energy_before": self.energy_before, "gain": self.gain,
                "metrics": {k: self.metrics[k] for k in METRIC_KEYS if k in self.metrics}}


def dart_sites(result, count: int = 4) -> np.ndarray:
    """(k, 2) (u, v) of up to ``count`` points of the outer loop with the most
    spring energy near them, at least two reaches apart."""
    from core.energy import Energy

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
    from core.errors import FlatweaveError
    from core.pipeline import flatten

    try:
        return flatten(surface, settings, initial=state)
    except FlatweaveError as exc:
        return str(exc)


def suggest_darts(result, count: int = 1, sites: int = 4, lengths=LENGTHS, min_gain: float = 0.03,
                  short_share: float = 0.95, workers: int | None = None,
                  progress=None) -> list[Proposal]:
    """Up to ``count`` darts, each the best of its round (module docstring),
    each :class:`Proposal` re-solved with the darts before it."""
    import os

    from core.sweep import _Runner

    if not (isinstance(count, int) and count >= 1):
        raise SettingsError(f"the number of suggested darts must be 1 or more, got {count!r}")
    if result.mesh.n_nodes < 16:
        raise SettingsError("the piece has too few nodes to suggest darts: use a smaller spacing")
    if workers is None:
        workers = max(1, min(os.cpu_count() or 1, 4))
    proposals: list[Proposal] = []
    current = result
    runner = _Runner(workers)
    try:
        for k in range(count):
            cands = candidate_darts(current, dart_sites(current, sites), lengths)
            if not cands:
                break
            cands = [(s, replace(d, name=f"suggested dart {len(current.settings.darts) + 1}", auto=True))
                     for s, d in cands]
            jobs = [(current.surface, replace(current.settings, darts=current.settings.darts + (d,)),
                     current.state()) for _, d in cands]
            solved = runner.map(jobs, _solve)
            if progress is not None:
                progress(k + 1, count)
            # a worker's result holds a copy of the surface: give it back the caller's own
            ok = [(s, d, replace(r, surface=current.surface)) for (s, d), r in zip(cands, solved)
                  if not isinstance(r, str)]
            if not ok:
                break
            e0 = float(current.metrics["energy"])
            # a dart that makes the pattern's outline or area worse is no help to the cutter
            m0 = current.metrics
            better = [c for c in ok if c[2].metrics["boundary_error_pct"] <= m0["boundary_error_pct"]
                      and c[2].metrics["area_error_pct"] <= m0["area_error_pct"]]
            ok = better or ok
            best_s, best_d, best_r = min(ok, key=lambda x: x[2].metrics["energy"])
            # the shortest at the best site that does most of the job
            gain = e0 - best_r.metrics["energy"]
            for s, d, r in ok:  # candidates are listed shortest first per site
                if s == best_s and e0 - r.metrics["energy"] >= short_share * gain:
                    best_d, best_r = d, r
                    break
            if (e0 - best_r.metrics["energy"]) < min_gain * e0:
                break
            proposals.append(Proposal(best_d, dict(best_r.metrics), e0, best_r))
            current = best_r
    finally:
        runner.close()
    return proposals
