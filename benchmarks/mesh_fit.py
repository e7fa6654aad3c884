"""How long a triangle mesh takes to become a surface, and how closely it follows the mesh.

    .venv/bin/python benchmarks/mesh_fit.py [--sizes 10000,30000,100000] [--repeat 3] [--igl PATH] [--out FILE]

For each size a garment-like panel with an arm hole and a sphere cap are
tessellated (a grid of about that many triangles), written as a binary STL
(trimesh), and opened with ``core.readers.open_path`` the way the CLI does:
read (header check and trimesh), repair and checks (``clean_mesh``), the
conformal map (``lscm``) and the fit (``fit_bspline``, refined to
``FIT_TOL``). Stage times are taken by wrapping ``core.meshsurf``'s functions
in this script; the median of ``--repeat`` runs is reported, with the fit's
largest and mean deviation as percentages of the mesh's bounding-box
diagonal. With ``--igl PATH`` (a folder where ``pip install --target`` put
libigl) libigl's LSCM is timed on the same meshes beside ours. The
one-minute load average is printed with the table (the machine is shared).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import core.meshsurf as ms
from core.readers import open_path


def grid_mesh(f, nu, nv, keep=None):
    u, v = np.meshgrid(np.linspace(0, 1, nu), np.linspace(0, 1, nv), indexing="ij")
    u, v = u.ravel(), v.ravel()
    idx = np.arange(nu * nv).reshape(nu, nv)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    F = np.r_[np.stack([a, b, c], 1), np.stack([a, c, d], 1)]
    if keep is not None:
        F = F[keep(u[F].mean(axis=1), v[F].mean(axis=1))]
    used = np.unique(F)
    return f(u[used], v[used]), np.searchsorted(used, F)


def panel(u, v):
    x, y = 0.5 * u, 0.7 * v
    return np.stack([x, y, 0.25 * np.sin(np.pi * u) * (0.6 + 0.4 * np.sin(np.pi * v)) + 0.08 * u * v], 1)


def sphere_cap(u, v):
    x, y = 1.2 * (u - 0.5), 1.2 * (v - 0.5)
    return np.stack([x, y, np.sqrt(1 - x * x - y * y)], 1)


SHAPES = {"panel with a hole": (panel, lambda u, v: (u - 0.6) ** 2 + (v - 0.55) ** 2 > 0.15 ** 2, 1.0),
          "sphere cap": (sphere_cap, lambda u, v: (u - 0.5) ** 2 + (v - 0.5) ** 2 < 0.25, 4 / np.pi)}


class Timers:
    """Wrap core.meshsurf's stages with timers (this script only)."""

    STAGES = ("read_mesh", "clean_mesh", "lscm", "fit_bspline")

    def __init__(self):
        self.t = {}
        self.orig = {name: getattr(ms, name) for name in self.STAGES}
        for name in self.STAGES:
            setattr(ms, name, self._wrap(name, self.orig[name]))

    def _wrap(self, name, f):
        def timed(*a, **k):
            t0 = time.perf_counter()
            try:
                return f(*a, **k)
            finally:
                self.t[name] = self.t.get(name, 0.0) + time.perf_counter() - t0
        return timed

    def restore(self):
        for name, f in self.orig.items():
            setattr(ms, name, f)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="10000,30000,100000")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--igl", default=None, metavar="PATH", help="folder holding libigl (pip install --target)")
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    igl = None
    if args.igl:
        sys.path.insert(0, args.igl)
        import igl
    import trimesh
    sizes = [int(s) for s in args.sizes.split(",")]
    rows = []
    tmp = Path(tempfile.mkdtemp(prefix="mesh_fit_"))
    for size in sizes:
        for shape, (f, keep, factor) in SHAPES.items():
            n = int(round(np.sqrt(size * factor / 2))) + 1
            V, F = grid_mesh(f, n, n, keep)
            path = tmp / f"mesh_{size}.stl"
            path.write_bytes(trimesh.Trimesh(V, F, process=False).export(file_type="stl"))
            runs, stage_runs = [], []
            for _ in range(args.repeat):
                timers = Timers()
                t0 = time.perf_counter()
                try:
                    opened = open_path(path)
                finally:
                    timers.restore()
                runs.append(time.perf_counter() - t0)
                stage_runs.append(timers.t)
            fit = opened.surface.fit
            med = {k: statistics.median(r.get(k, 0.0) for r in stage_runs) for k in Timers.STAGES}
            row = {"shape": shape, "triangles": fit.triangles, "total": statistics.median(runs), **med,
                   "ctrl": "x".join(map(str, fit.ctrl)), "max_pct": 100 * fit.max_deviation / fit.size,
                   "mean_pct": 100 * fit.mean_deviation / fit.size, "igl": None}
            if igl is not None:
                import igl as _igl
                Vc, Fc, _ = ms.clean_mesh(*ms.read_mesh(path), path.name)
                loop = ms.boundary_loops(Fc)[0]
                b = np.array([loop[0], loop[len(loop) // 2]], dtype=np.int64)
                ts = []
                for _ in range(args.repeat):
                    t0 = time.perf_counter()
                    _igl.lscm(Vc, Fc.astype(np.int64), b, np.array([[0.0, 0.0], [1.0, 0.0]]))
                    ts.append(time.perf_counter() - t0)
                row["igl"] = statistics.median(ts)
            rows.append(row)
            path.unlink()
    load = os.getloadavg()[0]
    lines = [f"load average (1 min) {load:.2f} on {os.cpu_count()} cores; median of {args.repeat} runs; "
             f"seconds; deviation in % of the mesh's bounding-box diagonal", "",
             "| mesh | triangles | total s | read | repair | LSCM (ours) | LSCM (libigl) | fit | control net "
             "| max dev % | mean dev % |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['shape']} | {r['triangles']:,} | {r['total']:.2f} | {r['read_mesh']:.2f} | "
                     f"{r['clean_mesh']:.2f} | {r['lscm']:.2f} | "
                     f"{'-' if r['igl'] is None else format(r['igl'], '.2f')} | {r['fit_bspline']:.2f} | "
                     f"{r['ctrl']} | {r['max_pct']:.2g} | {r['mean_pct']:.2g} |")
    text = "\n".join(lines)
    print(text)
    if args.out:
        Path(args.out).write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
