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


def _project(nodes: int):
    """The bundled job, each ply's spacing set for about ``nodes`` nodes: (project, pieces)."""
    import numpy as np

    from flatweave.document.pieces import with_pieces
    from flatweave.geometry.region import cover_for
    from flatweave.reading.registry import open_path

    project = open_path(JOB).project
    pieces = [replace(p, settings=replace(p.settings, spacing=float(
        np.sqrt(cover_for(project.surface, p.settings.region).area / nodes)))) for p in project.pieces]
    return with_pieces(project, pieces, 0), pieces


def measure_book(nodes: int) -> dict:
    """The solved laminate's ply book (the cover and 24 pages) written, and its cut files as one
    DXF of blocks and an SVG per ply (the tiled PDFs aside: their time is the PDF exporter's, a
    page per A4 tile of each 1.5 m ply): seconds, pages and size."""
    import tempfile

    from pypdf import PdfReader

    from flatweave.document.cutfiles import export_pieces
    from flatweave.document.plybook import write_ply_book
    from flatweave.document.solving import solve_pieces

    project, _ = _project(nodes)
    solved, _ = solve_pieces(project)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        book = write_ply_book(solved, Path(tmp) / "book.pdf")
        book_s = time.perf_counter() - t0
        pages = len(PdfReader(str(book)).pages)
        t0 = time.perf_counter()
        export_pieces(solved, Path(tmp) / "cut", formats=(".dxf", ".svg"))
        cut_s = time.perf_counter() - t0
        return {"book_s": book_s, "pages": float(pages), "book_mb": book.stat().st_size / 2 ** 20,
                "dxf_svg_s": cut_s}


def measure_dask(nodes: int) -> dict:
    """The 24-ply job solved on a Dask ``LocalCluster`` (a worker process per
    core, one thread each) and in the local pool of as many workers, side by
    side in this run: seconds each, and the plies whose result is not the
    pool's bit for bit (issue 41: none). The cluster is started before the
    clock (a user's cluster is already running)."""
    import distributed
    import numpy as np

    from flatweave.document.solving import solve_pieces
    from flatweave.studies.sweep import default_workers

    project, _ = _project(nodes)
    workers = default_workers()
    with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as cluster:
        t0 = time.perf_counter()
        on_dask, _ = solve_pieces(project, cluster=cluster.scheduler_address)
        dask_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    pooled, _ = solve_pieces(project, workers=workers)
    pool_s = time.perf_counter() - t0

    def same(a, b) -> bool:
        return (a is not None and b is not None and np.array_equal(a.uv, b.uv)
                and np.array_equal(a.pattern.xy, b.pattern.xy) and a.status == b.status)

    differ = sum(not same(a.result, b.result) for a, b in zip(on_dask.pieces, pooled.pieces))
    return {"differ": float(differ), "dask_s": dask_s, "pool_s": pool_s, "dask_over_pool": dask_s / pool_s,
            "workers": float(workers), "plies": float(len(project.pieces))}


def measure(nodes: int) -> dict:
    import numpy as np

    from flatweave.document.solving import solve_pieces
    from flatweave.method.pipeline import flatten
    from flatweave.studies.sweep import default_workers

    project, pieces = _project(nodes)
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
