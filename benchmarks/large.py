"""Large plies (issue 44), measured by ``benchmarks/suite.py``:

- case ``large_ply``: the woven octant from the loaded surface to its pattern at n nodes (as
  ``file_to_pattern``), in a child process of its own so its peak memory is its own: the seconds;
- case ``large_ply_memory``: the same runs' peak resident memory (MB);
- case ``large_over_arap``: the same file to pattern over libigl's ARAP on the same piece (its nodes and
  cells as triangles), both in this process one after the other;
- case ``large_result_file``: the same runs' result file (``flatten --out``'s content, written by
  ``flatweave.files.write_json``): its size (MB) and the seconds it takes to read back, the JSON parsed
  and every node, spring and cell array decoded.

One child process a run measures all three; the cases share its numbers (a size's runs are kept, so
the memory and file cases read the runs the time case made in the same suite run).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent

_CHILD = r"""
import json, os, resource, sys, time
sys.path.insert(0, sys.argv[3])
from benchmarks.suite import _file_to_pattern
from flatweave.files import decode_array, write_json
from flatweave.method.result import result_to_dict

seconds, r = _file_to_pattern("octant", "woven", int(sys.argv[1]))
m = r.metrics
path = sys.argv[2]
t0 = time.perf_counter()
write_json(path, result_to_dict(r, "octant"))
write_s = time.perf_counter() - t0
t0 = time.perf_counter()
with open(path, "rb") as fh:
    doc = json.loads(fh.read())
arrays = [decode_array(v, k) for g in ("nodes", "springs", "cells") for k, v in doc[g].items() if isinstance(v, dict)]
load_s = time.perf_counter() - t0
print(json.dumps({"seconds": seconds, "solve_s": float(m["solve_seconds"]), "iterations": float(m["iterations"]),
                  "nodes": float(m["nodes"]), "energy": float(m["energy"]),
                  "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
                  "file_mb": os.path.getsize(path) / 1e6, "write_s": write_s, "load_s": load_s}))
"""

_runs: dict[int, list[dict]] = {}  # a size's measurements not yet read by the memory and file cases
_taken: dict[tuple[str, int], int] = {}


def _measure(nodes: int) -> dict:
    with tempfile.TemporaryDirectory(prefix="large_") as tmp:
        p = subprocess.run([sys.executable, "-c", _CHILD, str(nodes), str(Path(tmp) / "r.json"), str(ROOT)],
                           capture_output=True, text=True, cwd=ROOT, env=dict(os.environ, PYTHONPATH=str(ROOT)),
                           timeout=3600)
    if p.returncode != 0:
        raise RuntimeError(f"the large-ply run failed: {p.stderr.strip()[-400:]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def measure_time(nodes: int) -> dict:
    row = _measure(nodes)
    _runs.setdefault(nodes, []).append(row)
    return row


def shared(case: str, nodes: int) -> dict:
    """The next run of ``nodes`` the time case made in this process, once per case; a new one if none."""
    k = _taken.get((case, nodes), 0)
    _taken[(case, nodes)] = k + 1
    made = _runs.get(nodes, [])
    return made[k] if k < len(made) else _measure(nodes)


def _arap_seconds(V: np.ndarray, F: np.ndarray) -> tuple[float, np.ndarray]:
    """libigl's ARAP parameterisation as its tutorial (503) makes it: a harmonic map onto a circle as the
    start, then ARAP with the dynamic term and nothing fixed, 100 iterations at most: (seconds, uv)."""
    import igl

    t0 = time.perf_counter()
    bnd = igl.boundary_loop(F)
    start = igl.harmonic(V, F, bnd, igl.map_vertices_to_circle(V, bnd), 1)
    data = igl.ARAPData()
    data.max_iter = 100
    data.with_dynamics = True
    igl.arap_precomputation(V, F, 2, np.zeros(0, dtype=np.int64), data)
    uv = igl.arap_solve(np.zeros((0, 2)), data, np.ascontiguousarray(start))
    return time.perf_counter() - t0, uv


def over_arap(nodes: int) -> dict:
    """Our file to pattern of the woven octant at ``nodes`` over libigl's ARAP on the same piece: the
    result's nodes and its cells split into two triangles each, timed one after the other in this process."""
    from benchmarks.suite import _file_to_pattern

    ours, r = _file_to_pattern("octant", "woven", nodes)
    cells = r.mesh.cells
    F = np.ascontiguousarray(np.concatenate([cells[:, [0, 1, 2]], cells[:, [0, 2, 3]]]), dtype=np.int64)
    used = np.unique(F)
    remap = np.full(len(r.xyz), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    V = np.ascontiguousarray(r.xyz[used])
    arap, uv = _arap_seconds(V, remap[F])
    return {"ratio": ours / arap, "ours_s": ours, "arap_s": arap, "vertices": float(len(V)),
            "triangles": float(len(F))}
