"""The drape's Two-Neighbour fronts in bands against the front-by-front sweep, side by side.

    .venv/bin/python benchmarks/drape_band.py [--sizes 2500,10000] [--repeat 7]
        [--examples octant,garment,saddle] [--ref 334c087] [--out benchmarks/results/drape_band.md]

The reference is ``core/drape.py`` at the commit ``--ref`` (read with ``git
show``, loaded as a module of its own; both run on the same surface
evaluator, so only the drape differs). For every example and size:

1. the drape (``drape``), reference and current alternating, ``--repeat``
   times each: median seconds, and whether the two lay the same net (the
   same lattice positions; the largest (u, v) difference over the domain's
   size);
2. the refills of one solve with a dart and population control
   (``core.pipeline.flatten``; the solver's calls are recorded, then replayed
   on both sides, alternating), at the sizes up to ``--refill-max`` nodes.

Timings depend on the load (2 cores, other work running): the one-minute load
average is printed before and after; medians of alternating runs.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as _dt
import importlib.util
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import core.drape as drape_now  # noqa: E402
import core.pipeline as pipeline  # noqa: E402
from core.darts import PlaneDart  # noqa: E402
from core.examples import load_example  # noqa: E402
from core.mesh import MATERIALS  # noqa: E402
from core.quadrature import region_area  # noqa: E402


def load_reference(commit: str):
    text = subprocess.run(["git", "-C", str(ROOT), "show", f"{commit}:core/drape.py"], check=True,
                          capture_output=True, text=True).stdout
    path = Path(tempfile.mkdtemp()) / "drape_reference.py"
    path.write_text(text)
    spec = importlib.util.spec_from_file_location("drape_reference", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules["drape_reference"] = mod  # dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


def alternate(fns: dict, repeat: int) -> dict:
    """Median seconds of every function, run in turn ``repeat`` times (after one warm-up each)."""
    for fn in fns.values():
        fn()
    times = {k: [] for k in fns}
    for _ in range(repeat):
        for k, fn in fns.items():
            t = time.perf_counter()
            fn()
            times[k].append(time.perf_counter() - t)
    return {k: float(np.median(v)) for k, v in times.items()}


def compare(surface, ij_a, uv_a, ij_b, uv_b) -> str:
    if len(ij_a) != len(ij_b):
        return f"DIFFERENT ({len(ij_a)} and {len(ij_b)} nodes)"
    oa, ob = np.lexsort((ij_a[:, 1], ij_a[:, 0])), np.lexsort((ij_b[:, 1], ij_b[:, 0]))
    if not np.array_equal(ij_a[oa], ij_b[ob]):
        return "DIFFERENT positions"
    size = surface.domain[:, 1] - surface.domain[:, 0]
    d = float(np.max(np.abs(uv_a[oa] - uv_b[ob]) / size, initial=0.0))
    return f"same positions, (u, v) to {d:.1e}" + ("" if d <= 1e-10 else " OVER 1e-10")


def dart_for(surface) -> PlaneDart:
    """A plane dart across the surface beside the seed, ending inside it (tests/test_drape_band.py)."""
    c = surface.points(surface.domain.mean(axis=1)[None])[0]
    pts = surface.points(np.stack(np.meshgrid(*[np.linspace(*d, 9) for d in surface.domain]), -1).reshape(-1, 2))
    ext = pts.max(axis=0) - pts.min(axis=0)
    n = np.array([1.0, 0.3, 0.1])
    d = -float(n @ (c + np.array([0.13, 0.0, 0.0]) * ext))
    lo, hi = pts.min(axis=0) - ext, pts.max(axis=0) + ext
    return PlaneDart((*n, d), tuple(float(x) for x in (lo[0], hi[0], lo[1], c[1], lo[2], hi[2])))


def load() -> str:
    try:
        return f"{os.getloadavg()[0]:.2f}"
    except OSError:
        return "?"


def _head() -> str:
    return subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True).stdout.strip()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="2500,10000")
    ap.add_argument("--examples", default="octant,garment,saddle")
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--refill-max", type=int, default=2500)
    ap.add_argument("--ref", default="334c087")
    ap.add_argument("--out", default=str(ROOT / "benchmarks/results/drape_band.md"))
    args = ap.parse_args()
    ref = load_reference(args.ref)
    material = MATERIALS["woven"]
    lines = [f"# Two-Neighbour fronts in bands: reference {args.ref} (front by front) against now", "",
             f"{_dt.date.today().isoformat()}, {platform.node()} ({platform.processor() or platform.machine()}, "
             f"{os.cpu_count()} cores), Python {platform.python_version()}, numpy {np.__version__}; woven; "
             f"medians of {args.repeat} alternating runs; load {load()} at the start", "",
             "| example | nodes | stage | reference ms | now ms | speed-up | same result |",
             "|---|---:|---|---:|---:|---:|---|"]
    for name in args.examples.split(","):
        s = load_example(name)
        for n in [int(x) for x in args.sizes.split(",")]:
            spacing = float(np.sqrt(region_area(s) / n))
            out = {}
            med = alternate({"ref": lambda: out.__setitem__("ref", ref.drape(s, ref.DrapeSettings(spacing), material)),
                             "now": lambda: out.__setitem__("now", drape_now.drape(s, drape_now.DrapeSettings(spacing),
                                                                                   material))}, args.repeat)
            a, b = out["ref"], out["now"]
            nodes = b.mesh.n_nodes
            rows = [("drape", med, compare(s, a.mesh.ij, a.uv, b.mesh.ij, b.uv))]
            if n <= args.refill_max:
                calls = []
                recorded = pipeline.refill

                def record(*a, **k):
                    calls.append((a, k))
                    return recorded(*a, **k)

                pipeline.refill = record
                try:
                    pipeline.flatten(s, pipeline.FlattenSettings(spacing=spacing, material=material,
                                                                 darts=(dart_for(s),)))
                finally:
                    pipeline.refill = recorded
                got = {}

                def replay(mod, key):
                    def run():
                        got[key] = [mod.refill(a[0], mod.DrapeSettings(**dataclasses.asdict(a[1])), *a[2:], **k)
                                    for a, k in calls]
                    return run

                med = alternate({"ref": replay(ref, "ref"), "now": replay(drape_now, "now")}, args.repeat)
                same = all(np.array_equal(x[0], y[0]) and
                           np.all(np.abs(x[1] - y[1]) <= 1e-10 * (s.domain[:, 1] - s.domain[:, 0]))
                           for x, y in zip(got["ref"], got["now"]))
                added = sum(len(x[0]) for x in got["now"])
                rows.append((f"refill x{len(calls)} of a dart solve ({added} nodes added)", med,
                             "same positions in the same order, (u, v) within 1e-10" if same else "DIFFERENT"))
            for stage, m, same_text in rows:
                lines.append(f"| {name} | {nodes:,} | {stage} | {1e3 * m['ref']:.1f} | {1e3 * m['now']:.1f} | "
                             f"{m['ref'] / m['now']:.2f}x | {same_text} |")
                print(lines[-1], flush=True)
    lines += ["", f"Load {load()} at the end. Current code: `core/drape.py` of this checkout (git {_head()})."]
    text = "\n".join(lines) + "\n"
    print(text)
    Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
