"""The orientation sweep's time (issue 23: a 12-angle sweep of a 2,500-node piece in under 5 s).

Measured by ``benchmarks/suite.py`` (case ``sweep_12_angles``): the woven
octant at about ``nodes`` nodes, 12 weft angles over one period, with the
sweep's own worker pool and default worker count (the window's and the CLI's
case; the pool stays warm between sweeps in one process, as in the window).
"""

from __future__ import annotations

import time

from benchmarks.suite import _area, _settings, _surface


def measure(nodes: int, angles: int = 12) -> dict:
    from flatweave.studies.sweep import default_workers, sweep

    s = _surface("octant")
    settings = _settings("octant", nodes)
    t0 = time.perf_counter()
    r = sweep(s, settings, angles=angles, area=_area("octant"))
    seconds = time.perf_counter() - t0
    return {"seconds": seconds, "iterations": float(sum(int(x.get("iterations", 0)) for x in r.rows)),
            "best_angle_deg": float(r.best["angle_deg"]), "nodes": float(r.best["nodes"]),
            "workers": float(default_workers())}
