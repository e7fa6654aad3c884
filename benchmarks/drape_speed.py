"""The drape, refill and surface evaluation against a reference commit, side by side.

    .venv/bin/python benchmarks/drape_speed.py [--sizes 2500,10000,40000] [--repeat 5]
        [--ref a0de682] [--out benchmarks/results/drape_speed.md]

The reference is ``core/drape.py`` and ``core/nurbs.py`` as they were at the
commit ``--ref`` (read with ``git show``, loaded as modules of their own; the
reference drape runs on a reference surface, so neither side borrows the
other's evaluator). For every size, on the woven octant:

1. the drape (``core.drape.drape``), reference and current alternating,
   ``--repeat`` times each: median seconds, and whether the two lay the same
   net (the same lattice positions, the largest (u, v) and xyz difference);
2. the refills of one solve with population control (``core.pipeline.flatten``;
   the solver's calls are recorded, then replayed on both sides, alternating);
3. the surface's points and first derivatives (``derivatives``) and the full
   evaluation with normals (``evaluate``) at the solved mesh's (u, v).

Timings depend on the load (2 cores, other work running): the one-minute
load average is printed before and after; medians of alternating runs.
"""

from __future__ import annotations

import argparse
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
from core.examples import load_example  # noqa: E402
from core.mesh import MATERIALS  # noqa: E402
from core.quadrature import region_area  # noqa: E402


def load_reference(commit: str, name: str, module: str):
    """``core/<name>.py`` at ``commit`` as a module called ``module``."""
    text = subprocess.run(["git", "-C", str(ROOT), "show", f"{commit}:core/{name}.py"], check=True,
                          capture_output=True, text=True).stdout
    path = Path(tempfile.mkdtemp()) / f"{module}.py"
    path.write_text(text)
    spec = importlib.util.spec_from_file_location(module, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[module] = mod  # dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


def reference_surface(nurbs_ref, s):
    return nurbs_ref.NurbsSurface(s.degree_u, s.degree_v, s.knots_u, s.knots_v, s.ctrlpts, s.weights)


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


def same_net(a, b) -> str:
    if a.mesh.n_nodes != b.mesh.n_nodes or not np.array_equal(a.mesh.ij, b.mesh.ij):
        sa, sb = set(map(tuple, a.mesh.ij)), set(map(tuple, b.mesh.ij))
        return f"different: {a.mesh.n_nodes} / {b.mesh.n_nodes} nodes, {len(sa - sb)} / {len(sb - sa)} own positions"
    return (f"same positions; largest (u, v) difference {np.abs(a.uv - b.uv).max():.1e}, "
            f"xyz {np.abs(a.xyz - b.xyz).max():.1e}")


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="2500,10000,40000")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--ref", default="a0de682", help="reference commit (default a0de682, session 9's base)")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "drape_speed.md")
    args = ap.parse_args()
    nurbs_ref = load_reference(args.ref, "nurbs", "nurbs_ref")
    drape_ref = load_reference(args.ref, "drape", "drape_ref")
    s = load_example("octant")
    s_ref = reference_surface(nurbs_ref, s)
    material = MATERIALS["woven"]
    lines = [f"# Drape, refill and surface evaluation: reference {args.ref} against now",
             "", f"{_dt.date.today().isoformat()}, {platform.node()} ({platform.processor() or platform.machine()}, "
             f"{os.cpu_count()} cores), Python {platform.python_version()}, numpy {np.__version__}; "
             f"woven octant; medians of {args.repeat} alternating runs; load {load()} at the start", "",
             "| nodes | stage | reference ms | now ms | speed-up | same result |", "|---:|---|---:|---:|---:|---|"]
    for n in [int(x) for x in args.sizes.split(",")]:
        spacing = float(np.sqrt(region_area(s) / n))
        ds = drape_now.DrapeSettings(spacing)
        ds_ref = drape_ref.DrapeSettings(spacing)
        out = {}
        med = alternate({"ref": lambda: out.__setitem__("ref", drape_ref.drape(s_ref, ds_ref, material)),
                         "now": lambda: out.__setitem__("now", drape_now.drape(s, ds, material))}, args.repeat)
        nodes = out["now"].mesh.n_nodes
        rows = [("drape", med, same_net(out["ref"], out["now"]))]
        # the solver's refills, recorded from one solve with population control, replayed on both sides
        calls = []
        recorded = pipeline.refill

        def record(*a, **k):
            calls.append((a, k))
            return recorded(*a, **k)

        pipeline.refill = record
        try:
            result = pipeline.flatten(s, pipeline.FlattenSettings(spacing=spacing, material=material))
        finally:
            pipeline.refill = recorded
        got = {}

        def replay(mod, surface, key):
            def run():
                got[key] = [mod.refill(surface, *a[1:], **k) for a, k in calls]
            return run

        med = alternate({"ref": replay(drape_ref, s_ref, "ref"), "now": replay(drape_now, s, "now")}, args.repeat)
        same = all(np.array_equal(a[0], b[0]) and np.allclose(a[1], b[1], rtol=0, atol=1e-12)
                   for a, b in zip(got["ref"], got["now"]))
        added = sum(len(x[0]) for x in got["now"])
        rows.append((f"refill x{len(calls)} ({added} nodes added)", med,
                     "same positions and (u, v)" if same else "DIFFERENT"))
        uv = result.uv
        # the drape's call, the full evaluation, and the solver's (second derivatives, no normals)
        for what, kw in (("derivatives", {}), ("evaluate", {}), ("evaluate", {"second": True, "normals": False})):
            med = alternate({"ref": lambda w=what, kw=kw: getattr(s_ref, w)(uv, **kw),
                             "now": lambda w=what, kw=kw: getattr(s, w)(uv, **kw)}, args.repeat)
            a, b = getattr(s_ref, what)(uv, **kw), getattr(s, what)(uv, **kw)
            fields = ("xyz", "su", "sv", "normal", "suu", "suv", "svv")
            pairs = zip(a, b) if what == "derivatives" else ((getattr(a, f), getattr(b, f)) for f in fields)
            same = all((x is None and y is None) or np.array_equal(x, y) for x, y in pairs)
            label = "evaluate(second=True, normals=False)" if kw else what
            rows.append((f"surface {label} at {len(uv)} points", med, "bit for bit" if same else "DIFFERENT"))
        for stage, m, same_text in rows:
            lines.append(f"| {nodes:,} | {stage} | {1e3 * m['ref']:.1f} | {1e3 * m['now']:.1f} | "
                         f"{m['ref'] / m['now']:.2f}x | {same_text} |")
        print("\n".join(lines[-len(rows):]), flush=True)
    lines += ["", f"Load {load()} at the end. Current code: `core/drape.py`, `core/nurbs.py` of this checkout "
              f"(git {_head()})."]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        args.out.write_text(text)


def _head() -> str:
    r = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "core"], capture_output=True, text=True)
    return r.stdout.strip() + (" + uncommitted changes" if dirty.stdout.strip() else "")


if __name__ == "__main__":
    main()
