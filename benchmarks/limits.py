"""The documented input limits finish in a stated time (issue 45, item 5).

Measured by ``benchmarks/suite.py``:

- case ``mesh_info_at_limit``: a binary STL of a wavy open sheet of
  ``triangles`` triangles (up to MAX_TRIANGLES, the most a mesh file may have)
  and ``python -m flatweave info`` on it in a child process, as a user runs it:
  its wall time and its own peak memory; at most MAX_FIT_TRIANGLES the whole
  sheet is mapped and fitted, above it the mesh is read, repaired and described
  and ``info`` asks for a panel (``fitted`` 1 or 0);
- case ``net_area_at_limit``: a cubic control net of ``n`` x ``n`` points
  (400 x 400 the largest a surface file is given in practice) and its region's
  area and boundary length, as ``info`` computes them, in this process.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent

_CHILD = ("import resource, sys\n"
          "from flatweave.cli import main\n"
          "code = main(sys.argv[1:])\n"
          "print('PEAK_KB', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr)\n"
          "sys.exit(code)\n")


def write_sheet_stl(path: Path, triangles: int) -> int:
    """A binary STL of a wavy open sheet, 1 unit square, of about ``triangles``
    triangles (2 n^2), written straight from arrays; returns its count."""
    from tests.helpers import wavy_sheet

    V, F = wavy_sheet(max(int(round(np.sqrt(triangles / 2))), 1), amp=0.15)
    rec = np.zeros(len(F), dtype=[("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attr", "<u2")])
    rec["corners"] = V[F]
    with open(path, "wb") as fh:
        fh.write(b"flatweave benchmark sheet".ljust(80, b" "))
        fh.write(np.uint32(len(F)).tobytes())
        fh.write(rec.tobytes())
    return len(F)


def measure_mesh_info(triangles: int) -> dict:
    from flatweave.geometry.meshfit import MAX_FIT_TRIANGLES

    with tempfile.TemporaryDirectory(prefix="limits_") as tmp:
        path = Path(tmp) / "sheet.stl"
        count = write_sheet_stl(path, triangles)
        env = dict(os.environ, PYTHONPATH=str(ROOT))
        t0 = time.perf_counter()
        p = subprocess.run([sys.executable, "-c", _CHILD, "info", str(path), "--json"], capture_output=True,
                           text=True, env=env, timeout=600)
        seconds = time.perf_counter() - t0
    if p.returncode != 0:
        raise RuntimeError(f"info failed: {p.stderr.strip()[-300:]}")
    peak = [int(line.split()[1]) for line in p.stderr.splitlines() if line.startswith("PEAK_KB")]
    return {"seconds": seconds, "peak_mb": peak[0] / 1024 if peak else float("nan"),
            "fitted": float(count <= MAX_FIT_TRIANGLES), "triangles": count}


def measure_net_area(n: int) -> dict:
    from flatweave.geometry.meshfit import clamped_knots
    from flatweave.geometry.nurbs import NurbsSurface
    from flatweave.geometry.region import cover_for

    u = np.linspace(0.0, 1.0, n)
    U, V = np.meshgrid(u, u, indexing="ij")
    P = np.stack([U, V, 0.05 * np.sin(6 * U) * np.cos(5 * V)], -1)
    surface = NurbsSurface(3, 3, clamped_knots(n), clamped_knots(n), P)
    t0 = time.perf_counter()
    cover = cover_for(surface)  # the whole untrimmed domain, as info takes it
    area, length = cover.area, cover.boundary_length
    return {"seconds": time.perf_counter() - t0, "area": area, "boundary_length": length}
