"""Solve a project's pieces together (issue 41, "Solve all"): each piece's
flattening in a worker process, as many as asked (default one per core, at
most four), or on the workers of an existing Dask cluster (``cluster``, the
scheduler's address; issue 41, "Beyond one machine"), results gathered into
the project as they finish.

A piece is solved exactly as alone (:func:`flatweave.method.pipeline.flatten`
on the piece's surface with its settings, from a new drape), so its
result is the same bit for bit in the pool, on a cluster (whose workers run
the same flatweave, numpy and scipy) and in this process. A piece whose
solve fails (a one-line FlatweaveError) fails alone, with its message; a
worker that dies (killed, out of memory) breaks the pool: the pieces not yet
finished are then run again one by one, each in a pool of its own, and the one
whose worker dies again fails with one line. On a cluster a piece whose worker
died (the scheduler's KilledWorker) is likewise run again alone once the
others are done, and fails with one line if its worker dies again; a piece
whose task was lost (the scheduler gone) fails with one line. The others'
results are kept. A cluster that cannot be reached, or ``distributed`` not
installed, is a one-line SettingsError before anything is solved.
"""

from __future__ import annotations

import time
from concurrent.futures import FIRST_COMPLETED, CancelledError, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, replace
from typing import Callable

from flatweave.document.pieces import index_of, with_pieces
from flatweave.errors import FlatweaveError, SettingsError
from flatweave.geometry.quadrature import region_area
from flatweave.method import drape
from flatweave.method.pipeline import flatten
from flatweave.method.result import FlattenResult
from flatweave.studies.sweep import default_workers, pool_context

__all__ = ["PieceOutcome", "solve_pieces", "solve_piece", "piece_nodes", "memory_workers", "WORKER_BYTES"]

WORKER_DIED = "its worker process died (killed, or out of memory)"
TASK_LOST = "its task was lost on the Dask cluster (the scheduler went away)"
CONNECT_SECONDS = 10.0  # how long a scheduler (and a first worker) is waited for before it is said unreachable
WORKER_BYTES = 100_000_000  # a worker before its piece: flatweave, numpy and scipy imported (70 MB measured)


def piece_nodes(surface, settings, area: float | None = None) -> int:
    """At most the nodes a piece's mesh will have: ``area`` (default its surface's whole area, a
    bound for any region of it that costs no region's quadrature) over a cell's, at most its
    ``max_nodes`` (:func:`flatweave.method.drape.estimate_node_count`)."""
    area = region_area(surface) if area is None else area
    warp = settings.spacing if settings.spacing_warp is None else settings.spacing_warp
    return min(int(settings.max_nodes), drape.estimate_node_count(float(area), settings.spacing, warp))


def memory_workers(workers: int, nodes) -> int:
    """How many of ``workers`` processes the available memory holds at once, each solving one of
    pieces of ``nodes`` nodes (the largest together, at :data:`flatweave.method.drape.BYTES_PER_NODE`
    each, plus :data:`WORKER_BYTES`); at least 1, ``workers`` when the memory is not known."""
    memory = drape.available_memory()
    if memory is None:
        return workers
    n, used = 0, 0
    for k in sorted(nodes, reverse=True)[:workers]:
        used += WORKER_BYTES + drape.BYTES_PER_NODE * int(k)
        if used > memory:
            break
        n += 1
    return max(1, n)


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
                 on_done: Callable[[PieceOutcome], None] | None = None, fn=solve_piece, stop=None,
                 cluster: str | None = None):
    """``project`` with ``pieces`` (indices or names; default every piece)
    solved, and the outcomes in the order given: (project, [PieceOutcome]).

    ``workers`` processes (None: :func:`flatweave.studies.sweep.default_workers`;
    1: here, one after another), fewer when the available memory does not hold
    that many of the largest pieces at once (:func:`memory_workers`). ``cluster``: the address of an existing Dask
    cluster's scheduler (``"tcp://host:8786"``; needs ``flatweave[cluster]``),
    whose workers solve the pieces instead (not with ``workers``); its
    client is closed at the end, the cluster left running. ``on_done(outcome)``
    is called in this thread as each piece finishes. ``stop`` (a
    ``threading.Event``, optional): once set, no piece starts (those already
    running finish); the pieces not solved are left out of the outcomes.
    ``fn`` is the worker's function (tests replace it; on a cluster its
    workers must be able to import it)."""
    all_pieces = list(project.pieces)
    chosen = range(len(all_pieces)) if pieces is None else [index_of(project, k) for k in pieces]
    chosen = list(dict.fromkeys(chosen))  # each piece once, in the order first given
    jobs = {all_pieces[i].name: (all_pieces[i].name, all_pieces[i].surface, all_pieces[i].settings) for i in chosen}
    surfaces = {name: job[1] for name, job in jobs.items()}
    if cluster is not None and workers is not None:
        raise SettingsError("give worker processes or a Dask cluster, not both: the cluster's workers solve the pieces")
    workers = default_workers() if workers is None else max(1, int(workers))
    if cluster is None and workers > 1 and len(jobs) > 1:  # as many as the memory holds with the largest at once
        areas = {id(surface): region_area(surface) for surface in surfaces.values()}  # once a source
        workers = memory_workers(workers, [piece_nodes(surface, settings, areas[id(surface)])
                                           for _, surface, settings in jobs.values()])
    outcomes: dict[str, PieceOutcome] = {}

    def done(name, result, error, seconds):
        if result is not None and result.surface is not surfaces[name]:  # a copy from a worker: same numbers
            result = replace(result, surface=surfaces[name])
        outcomes[name] = out = PieceOutcome(name, result, error, seconds)
        if on_done is not None:
            on_done(out)

    stopped = (lambda: False) if stop is None else stop.is_set
    if not jobs:  # nothing asked: nothing started
        pass
    elif cluster is not None:
        _run_cluster(cluster, list(jobs.values()), fn, done, stopped)
    elif workers == 1 or len(jobs) == 1:
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


def _run_cluster(address: str, jobs, fn, done, stopped) -> None:
    """Run ``jobs`` on the workers of the Dask cluster whose scheduler is at
    ``address``; ``done(*fn(job))`` for each as it finishes, a job whose
    worker died (again, when run alone) or whose task was lost done as failed
    with one line. A one-line SettingsError, nothing run, when ``distributed``
    is missing or the scheduler (or a first worker) does not answer within
    :data:`CONNECT_SECONDS`."""
    try:
        import distributed
    except ImportError:
        raise SettingsError("solving on a Dask cluster needs distributed (pip install 'flatweave[cluster]')") from None
    if not isinstance(address, str) or not address.strip():
        # Client("") would start a cluster of its own in this process
        raise SettingsError(f"a Dask scheduler's address is like tcp://host:8786, got {address!r}")
    # made, then started: a Client whose start failed must be closed here, not left to the garbage
    # collector, whose close of it can come while another Client starts in this process and wait on
    # the lock that one holds (distributed's loop runner: seen as a hang under pytest-xdist)
    client = distributed.Client.__new__(distributed.Client)
    try:
        client.__init__(address, timeout=CONNECT_SECONDS, set_as_default=False)
    except OSError:  # refused, unknown host, no answer: distributed retries them all until the timeout
        client.close()
        raise SettingsError(f"no Dask scheduler answered at {address} within {CONNECT_SECONDS:g} s") from None
    except (ValueError, TypeError) as exc:  # no port, an unknown or unusable scheme
        client.close()
        raise SettingsError(f"{address} is not a Dask scheduler's address: {str(exc).splitlines()[0]}") from None
    try:
        try:
            client.wait_for_workers(1, timeout=CONNECT_SECONDS)
        except TimeoutError:
            raise SettingsError(f"the Dask cluster at {address} has no workers (none joined within "
                                f"{CONNECT_SECONDS:g} s)") from None
        killed = _run_tasks(client, distributed, jobs, fn, done, stopped, None)
        for job in killed:  # each again alone: a worker's death counts against every task it held, not only
            # the one that killed it, so a neighbour's piece may be among these
            if not stopped() and _run_tasks(client, distributed, [job], fn, done, stopped, 1):
                done(job[0], None, WORKER_DIED, 0.0)
    finally:
        client.close()  # the client only: the cluster is the user's


def _run_tasks(client, distributed, jobs, fn, done, stopped, slots: int | None) -> list:
    """Run ``jobs`` as tasks of ``client``'s cluster, at most ``slots`` at once
    (None: as many as its workers have threads, so that no task waits queued
    on the cluster and, once ``stopped()``, none starts); ``done(...)`` for
    each as it finishes. Returns the jobs whose worker died (KilledWorker)."""
    queue = list(jobs)
    running = distributed.as_completed(loop=client.loop)  # this client's, not a default one
    sent, killed = {}, []

    def send():
        room = slots or max(1, sum(client.nthreads().values()))
        while queue and running.count() < room and not stopped():
            job = queue.pop(0)
            future = client.submit(fn, job, pure=False)  # pure=False: each piece solved, never a cached result
            sent[future] = job
            running.add(future)

    send()
    for future in running:
        job = sent.pop(future)
        try:
            out = future.result()
        except distributed.KilledWorker:
            killed.append(job)
        except CancelledError:  # we cancel nothing: the scheduler (or the connection to it) went away
            done(job[0], None, TASK_LOST, 0.0)
        except FlatweaveError as exc:  # raised by fn itself, outside solve_piece's own catch
            done(job[0], None, str(exc).splitlines()[0] if str(exc) else type(exc).__name__, 0.0)
        else:
            done(*out)
        future.release()
        send()
    return killed
