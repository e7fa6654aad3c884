"""Solve a project's pieces together (issue 41, "Solve all"): each piece's
flattening in a worker process, as many as asked (default one per core, at
most four), results gathered into the project as they finish.

A piece is solved exactly as alone (:func:`flatweave.method.pipeline.flatten`
on the project's surface with the piece's settings, from a new drape), so its
result is the same bit for bit in the pool as in this process. A piece whose
solve fails (a one-line FlatweaveError) fails alone, with its message; a
worker that dies (killed, out of memory) breaks the pool: the pieces not yet
finished are then run again one by one, each in a pool of its own, and the one
whose worker dies again fails with one line. The others' results are kept.
"""

from __future__ import annotations

import time
from concurrent.futures import FIRST_COMPLETED, CancelledError, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, replace
from typing import Callable

from flatweave.document.pieces import index_of, with_pieces
from flatweave.errors import FlatweaveError
from flatweave.method.pipeline import flatten
from flatweave.method.result import FlattenResult
from flatweave.studies.sweep import default_workers, pool_context

__all__ = ["PieceOutcome", "solve_pieces", "solve_piece"]

WORKER_DIED = "its worker process died (killed, or out of memory)"


@dataclass(frozen=True)
class PieceOutcome:
    """What became of one piece: its result (None when it failed), the one-line
    ``error`` when it failed, and the seconds its solve took."""

    name: str
    result: FlattenResult | None
    error: str = ""
    seconds: float = 0.0


def solve_piece(job) -> tuple:
    """One piece's solve, in a worker: ``job`` = (name, surface, settings);
    returns (name, result or None, error, seconds)."""
    name, surface, settings = job
    t0 = time.perf_counter()
    try:
        result = flatten(surface, settings)
    except FlatweaveError as exc:
        return name, None, str(exc).splitlines()[0] if str(exc) else type(exc).__name__, time.perf_counter() - t0
    return name, result, "", time.perf_counter() - t0


def solve_pieces(project, pieces=None, workers: int | None = None,
                 on_done: Callable[[PieceOutcome], None] | None = None, fn=solve_piece, stop=None):
    """``project`` with ``pieces`` (indices or names; default every piece)
    solved, and the outcomes in the order given: (project, [PieceOutcome]).

    ``workers`` processes (None: :func:`flatweave.studies.sweep.default_workers`;
    1: here, one after another). ``on_done(outcome)`` is called in this thread
    as each piece finishes. ``stop`` (a ``threading.Event``, optional): once set,
    no piece starts (those already running finish); the pieces not solved are
    left out of the outcomes. ``fn`` is the worker's function (tests replace it)."""
    all_pieces = list(project.pieces)
    chosen = range(len(all_pieces)) if pieces is None else [index_of(project, k) for k in pieces]
    chosen = list(dict.fromkeys(chosen))  # each piece once, in the order first given
    jobs = {all_pieces[i].name: (all_pieces[i].name, project.surface, all_pieces[i].settings) for i in chosen}
    workers = default_workers() if workers is None else max(1, int(workers))
    outcomes: dict[str, PieceOutcome] = {}

    def done(name, result, error, seconds):
        if result is not None and result.surface is not project.surface:  # a copy from a worker: same numbers
            result = replace(result, surface=project.surface)
        outcomes[name] = out = PieceOutcome(name, result, error, seconds)
        if on_done is not None:
            on_done(out)

    stopped = (lambda: False) if stop is None else stop.is_set
    if workers == 1 or len(jobs) == 1:
        for job in jobs.values():
            if stopped():
                break
            done(*fn(job))
    else:
        left = _run_pool(list(jobs.values()), min(workers, len(jobs)), fn, done, stopped)
        for job in left:  # the pool broke: each piece not finished in a pool of its own
            if not stopped() and _run_pool([job], 1, fn, done, stopped):
                done(job[0], None, WORKER_DIED, 0.0)
    solved = [replace(p, result=outcomes[p.name].result) if p.name in outcomes and outcomes[p.name].result
              is not None else p for p in all_pieces]
    return with_pieces(project, solved, project.piece_index), [outcomes[n] for n in jobs if n in outcomes]


def _run_pool(jobs, workers: int, fn, done, stopped) -> list:
    """Run ``jobs`` in a pool of ``workers``; ``done(*fn(job))`` for each as it
    finishes; once ``stopped()``, the jobs not started are cancelled. Returns
    the jobs left unfinished when a worker died ([] when none)."""
    pool = ProcessPoolExecutor(workers, mp_context=pool_context())
    futures = {pool.submit(fn, job): job for job in jobs}
    left = []
    try:
        pending = set(futures)
        while pending:
            finished, pending = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
            for f in finished:
                try:
                    out = f.result()
                except BrokenProcessPool:
                    left.append(futures[f])
                    continue
                except CancelledError:
                    continue
                done(*out)
            if stopped():
                for f in pending:
                    f.cancel()
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    return left
