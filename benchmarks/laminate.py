"""Solve all on a laminate (issue 41's target): the bundled 24-ply job
(``resources/jobs/dome-laminate.toml``: the dome, 0/45/-45/90, carbon then
glass twill, 5 mm drop-offs) at about ``nodes`` nodes a ply, solved by
:func:`flatweave.document.solving.solve_pieces` in a pool of the machine's
default workers, against one ply alone (the first, median of three) times
24 over the workers (``ratio``, issue 41: at most 2), and against every ply
solved alone one after another over the workers (``over_all_alone``: the
plies differ, a 45-degree ply on the dome takes longer than the 0-degree
first one).
Peak memory is the largest resident set of this process and of its workers
(``getrusage``: the workers are children).

Measured by ``benchmarks/suite.py`` (case ``laminate_solve_all``).
"""

from __future__ import annotations

import resource
import statistics
import time
from dataclasses import replace
from pathlib import Path

JOB = Path(__file__).resolve().parent.parent / "resources" / "jobs" / "dome-laminate.toml"


def measure(nodes: int) -> dict:
    import numpy as np

    from flatweave.document.pieces import with_pieces
    from flatweave.document.solving import solve_pieces
    from flatweave.geometry.region import cover_for
    from flatweave.method.pipeline import flatten
    from flatweave.reading.registry import open_path
    from flatweave.studies.sweep import default_workers

    project = open_path(JOB).project
    pieces = [replace(p, settings=replace(p.settings, spacing=float(
        np.sqrt(cover_for(project.surface, p.settings.region).area / nodes)))) for p in project.pieces]
    project = with_pieces(project, pieces, 0)
    one = []
    for _ in range(3):
        t0 = time.perf_counter()
        r = flatten(project.surface, pieces[0].settings)
        one.append(time.perf_counter() - t0)
    alone = 0.0  # every ply solved alone, one after another: the pool's ideal is this over the workers
    for p in pieces:
        t0 = time.perf_counter()
        flatten(project.surface, p.settings)
        alone += time.perf_counter() - t0
    workers = default_workers()
    t0 = time.perf_counter()
    solved, outcomes = solve_pieces(project, workers=workers)
    seconds = time.perf_counter() - t0
    one_s = statistics.median(one)
    peak_mb = max(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
                  resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss) / 1024.0
    return {"ratio": seconds / (one_s * len(pieces) / workers), "seconds": seconds, "one_ply_s": one_s,
            "over_all_alone": seconds / (alone / workers), "all_alone_s": alone,
            "workers": float(workers), "plies": float(len(pieces)), "failed": float(sum(o.result is None
                                                                                      for o in outcomes)),
            "nodes": float(np.median([o.result.metrics["nodes"] for o in outcomes if o.result is not None])),
            "peak_mb": peak_mb, "first_ply_nodes": float(r.metrics["nodes"])}
