"""The best fibre orientation: solve the piece at several weft angles (and
seeds) and rank the results.

A row is one solve from a new drape, with its verdict (the result's
``status`` and ``unusable``: the metrics past their bad limit,
:class:`flatweave.method.metrics.Verdict`). Rows are ranked by what the designer sees
first: a usable pattern (no metric past its bad limit) before one with one,
before one with two, ...; then by the share of the area sheared past the lock
angle (where the cloth wrinkles), then the largest shear, then the boundary
error (:data:`RANK_KEYS`; :func:`rank_rows` says which differences count as
ties). The woven lattice with
equal weft and warp repeats every 90 degrees of weft angle (weft and warp
swap), any other every 180, so the sweep covers one period.

:func:`sweep` runs a coarse sweep (``angles`` evenly over the period, times
``seeds`` seeds) and, with ``refine``, narrows the best angle down by halving
the step around it until it is below ``resolution`` degrees. The solves are
independent: they run in worker processes (``workers``; one runs them here).
"""

from __future__ import annotations

import math
import multiprocessing
import os
import threading
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, replace

import numpy as np

from flatweave.errors import SettingsError
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.geometry.region import cover_for
from flatweave.errors import FlatweaveError
from flatweave.method.pipeline import flatten
from flatweave.method.result import judge_result

__all__ = ["RANK_KEYS", "SweepResult", "angle_period", "sweep_seeds", "rank_rows", "sweep", "warm_pool",
           "default_workers", "pool_context"]

RANK_KEYS = ("area_beyond_lock_pct", "max_shear_deg", "boundary_error_pct")
"""The metrics a sweep ranks by after the rows' usability (:func:`rank_rows`), most important first;
smaller is better."""

ROW_KEYS = RANK_KEYS + ("area_error_pct", "energy", "p95_shear_deg", "max_thread_strain_pct", "nodes",
                        "iterations", "uncovered_pct")


def angle_period(settings) -> float:
    """90 degrees when weft and warp are alike (stiffness and spacing), else 180."""
    m = settings.material
    same_spacing = settings.spacing_warp is None or math.isclose(settings.spacing_warp, settings.spacing)
    return 90.0 if (math.isclose(m.k_weft, m.k_warp) and same_spacing) else 180.0


def sweep_seeds(surface: NurbsSurface, region, count: int, first: tuple[float, float] | None = None):
    """``count`` seeds (fractions of the domain) well inside the region: the
    given (or default) seed first, then points at least half as far from the
    edge as the farthest one, each as far as possible from those chosen."""
    cover = cover_for(surface, region)
    seeds = [tuple(float(x) for x in (first if first is not None else cover.default_seed))]
    if count <= 1:
        return seeds
    g = (np.arange(21) + 0.5) / 21
    f = np.column_stack([a.ravel() for a in np.meshgrid(g, g)])
    uv = cover.seed_uv(f)
    inside = cover.contains(uv)
    f, uv = f[inside], uv[inside]
    if len(f) == 0:
        return seeds
    depth = cover.edge_distance(uv)
    keep = depth >= 0.5 * depth.max()
    f = f[keep]
    dist = np.linalg.norm(f - np.asarray(seeds[0]), axis=1)
    while len(seeds) < count and len(f):
        k = int(np.argmax(dist))
        if dist[k] <= 1e-9:
            break
        seeds.append((float(f[k, 0]), float(f[k, 1])))
        dist = np.minimum(dist, np.linalg.norm(f - f[k], axis=1))
    return seeds


SHEAR_TIE_DEG = 0.05
"""Largest shears this close to the lowest rank as equal: the largest shear is a
maximum over cells and moves by a few hundredths of a degree from one angle to
the next where no cell changes (the saddle's and garment's are flat within 0.05
degrees over 15 degrees of weft angle), so the boundary error decides there."""

BEYOND_TIE_PCT = 0.01
"""Shares of the area beyond the lock angle this close to the lowest rank as equal."""


def rank_rows(rows) -> list[dict]:
    """The rows best first: by the number of metrics past their bad limit
    (``unusable``; none: a usable pattern), then the area beyond the lock
    angle, then the largest shear, then the boundary error, with the ties
    above; failed rows last."""
    ok = [r for r in rows if not r.get("error")]
    if not ok:
        return list(rows)
    beyond0 = min(r["area_beyond_lock_pct"] for r in ok)
    shear0 = min(r["max_shear_deg"] for r in ok)

    def key(r):
        if r.get("error"):
            return (1, 0, 0, 0, 0.0, r["angle_deg"], tuple(r["seed"]))
        return (0, len(r.get("unusable", ())),
                math.floor((r["area_beyond_lock_pct"] - beyond0) / BEYOND_TIE_PCT + 1e-9),
                math.floor((r["max_shear_deg"] - shear0) / SHEAR_TIE_DEG + 1e-9),
                round(r["boundary_error_pct"], 9), r["angle_deg"], tuple(r["seed"]))  # exact twins: lower angle

    return sorted(rows, key=key)


@dataclass(frozen=True)
class SweepResult:
    """Ranked rows (best first) and the best row; ``to_dict`` is the file form."""

    rows: tuple[dict, ...]
    lock_deg: float
    period_deg: float
    seconds: float

    @property
    def best(self) -> dict:
        return self.rows[0]

    def to_dict(self) -> dict:
        return {"rows": [dict(r) for r in self.rows], "best": dict(self.best), "lock_deg": self.lock_deg,
                "period_deg": self.period_deg, "rank_by": ["unusable", *RANK_KEYS],
                "ties": {"area_beyond_lock_pct": BEYOND_TIE_PCT, "max_shear_deg": SHEAR_TIE_DEG},
                "seconds": self.seconds}


def _solve_row(job) -> dict:
    surface, settings, area = job

    row = {"angle_deg": float(settings.angle_deg), "seed": [float(settings.seed[0]), float(settings.seed[1])]}
    try:
        result = flatten(surface, settings, area=area)
    except FlatweaveError as exc:
        row["error"] = str(exc)
        return row
    m = result.metrics
    for k in ROW_KEYS:
        if k in m:
            row[k] = float(m[k]) if not isinstance(m[k], int) else int(m[k])
    row["status"] = result.status
    row["unusable"] = list(judge_result(result).unusable)
    return row


def pool_context():
    """The multiprocessing context worker pools use (fork where it is safe, else a fork server)."""
    # fork is quick and safe in a process with one thread (the CLI); a process
    # with threads (the window, a test runner with Qt) forks a server first
    if threading.active_count() == 1 and "fork" in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("fork")
    return multiprocessing.get_context("forkserver" if os.name == "posix" else "spawn")


_POOLS: dict[int, ProcessPoolExecutor] = {}
_POOLS_LOCK = threading.Lock()


def warm_pool(workers: int | None = None) -> ProcessPoolExecutor | None:
    """The pool of ``workers`` processes (None: :func:`default_workers`), made
    on the first call and kept for later sweeps: a new pool's processes pay
    their imports on their first row (0.85 s for two forkserver workers, 0.01 s
    forked), so the window can call this when its sweep dialog opens and every
    sweep after the first starts warm. None for one worker (rows run here)."""
    workers = default_workers() if workers is None else workers
    if workers <= 1:
        return None
    with _POOLS_LOCK:
        pool = _POOLS.get(workers)
        if pool is None:
            pool = _POOLS[workers] = ProcessPoolExecutor(workers, mp_context=pool_context())
            for _ in range(workers):  # each worker imports the solver now, not on its first row
                pool.submit(_preload)
        return pool


def _preload() -> None:
    import time

    time.sleep(0.05)  # long enough that the next preload goes to another worker


def _drop_pool(workers: int, pool) -> None:
    with _POOLS_LOCK:
        if _POOLS.get(workers) is pool:
            del _POOLS[workers]
    pool.shutdown(wait=False, cancel_futures=True)


def default_workers() -> int:
    """One worker per core, at most 4."""
    return max(1, min(os.cpu_count() or 1, 4))


class Runner:
    def __init__(self, workers: int):
        self.workers = workers

    def map(self, jobs, fn=None):
        fn = fn or _solve_row
        pool = warm_pool(self.workers) if len(jobs) > 1 else None
        if pool is None:
            return [fn(j) for j in jobs]
        futures = [pool.submit(fn, j) for j in jobs]
        try:
            return [f.result() for f in futures]
        except BrokenProcessPool:
            # a worker died (killed, out of memory): the next sweep gets a new pool
            _drop_pool(self.workers, pool)
            raise
        except BaseException:
            for f in futures:
                f.cancel()
            raise

    def close(self):
        pass


def _wrap(angle: float, period: float) -> float:
    a = math.fmod(angle, period)
    return a + period if a < 0 else a


def sweep(surface: NurbsSurface, settings, angles: int = 12, seeds: int = 1, lock_deg: float | None = None,
          refine: bool = False, resolution: float = 0.25, workers: int | None = None,
          area: float | None = None, progress=None) -> SweepResult:
    """Solve ``settings`` at ``angles`` weft angles over one period (starting
    at ``settings.angle_deg``) times ``seeds`` seeds, rank the rows; with
    ``refine``, halve the angle step around the best row's angle (its seed
    kept) while the step is at least ``resolution``. ``lock_deg`` replaces the
    material's lock angle (None: the material's). ``progress(done, total)`` is
    called after each batch."""
    import time

    if not (isinstance(angles, int) and angles >= 1):
        raise SettingsError(f"--angles must be a positive whole number, got {angles!r}")
    if not (isinstance(seeds, int) and seeds >= 1):
        raise SettingsError(f"--seeds must be a positive whole number, got {seeds!r}")
    if not (resolution > 0):
        raise SettingsError(f"sweep resolution must be positive, got {resolution!r}")
    t0 = time.perf_counter()
    if lock_deg is not None:
        m = settings.material  # the warning angle does not rank; it must stay below the lock
        settings = replace(settings, material=replace(m, lock_deg=float(lock_deg),
                                                      warn_deg=min(m.warn_deg, 0.5 * float(lock_deg))))
    lock_deg = settings.material.lock_deg
    period = angle_period(settings)
    step = period / angles
    seed_list = sweep_seeds(surface, settings.region, seeds, settings.seed)
    if workers is None:
        workers = default_workers()

    def jobs(pairs):
        return [(surface, replace(settings, angle_deg=round(a, 9), seed=s), area) for a, s in pairs]

    pairs = [(_wrap(settings.angle_deg + k * step, period), s) for s in seed_list for k in range(angles)]
    runner = Runner(min(workers, len(pairs)))
    try:
        rows = runner.map(jobs(pairs))
        if progress is not None:
            progress(len(rows), len(rows))
        done = {(round(r["angle_deg"], 6), tuple(r["seed"])) for r in rows}
        while refine and step / 2 >= resolution and not rows_failed(rows):
            step /= 2
            best = rank_rows(rows)[0]
            s = tuple(best["seed"])
            new = [(_wrap(best["angle_deg"] + d, period), s) for d in (-step, step)]
            new = [p for p in new if (round(p[0], 6), p[1]) not in done]
            if not new:
                continue
            rows += runner.map(jobs(new))
            done |= {(round(a, 6), sd) for a, sd in new}
            if progress is not None:
                progress(len(rows), len(rows))
    finally:
        runner.close()
    rows = rank_rows(rows)
    if rows[0].get("error"):
        raise SettingsError(f"no solve of the sweep succeeded: {rows[0]['error']}")
    return SweepResult(tuple(rows), float(lock_deg), period, time.perf_counter() - t0)


def rows_failed(rows) -> bool:
    return all(r.get("error") for r in rows)
