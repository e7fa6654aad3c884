"""How long joining several CAD faces takes (``--faces``, core.cad.join_faces), stage by stage.

    .venv/bin/python benchmarks/faces_join.py [--repeat 3] [--out FILE]

Two STEP files are made with Open CASCADE (the shapes of
tests/test_faces_join.py): a plate, a quarter-cylinder fillet and a plate
(three faces), and the lid of a box with rounded edges (a plane, four
cylinders, four sphere corners: nine faces). Each is read as the CLI reads
it (``read_cad_faces``, a child process), then joined; the stages are timed
by wrapping ``core.cad``'s and ``core.meshsurf``'s functions in this script:
the child that tessellates (its start and OCP's import included), welding
and densifying, the repair and checks (``clean_mesh``), and the map and fit
(``mesh_surface``). Medians of ``--repeat`` runs; the one-minute load
average is printed with the table (the machine is shared).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import core.cad as cad
import core.meshsurf as ms


def timed(module, name, bucket):
    original = getattr(module, name)

    def wrapper(*args, **kwargs):
        t = time.perf_counter()
        try:
            return original(*args, **kwargs)
        finally:
            bucket[name] = bucket.get(name, 0.0) + time.perf_counter() - t
    setattr(module, name, wrapper)
    return original


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--out", default=None, help="append the table to this Markdown file")
    args = p.parse_args()
    from tests import cadfiles as cf
    from tests.test_faces_join import fillet_shell, lid_faces, rounded_box

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        fillet = cf.write_step(fillet_shell(), Path(tmp) / "fillet.step")
        box = cf.write_step(rounded_box(), Path(tmp) / "rounded.step")
        for label, path, pick in (("plate + fillet + plate", fillet, lambda c: (0, 1, 2)),
                                  ("rounded box lid", box, lid_faces)):
            runs = []
            for _ in range(args.repeat):
                bucket = {}
                t0 = time.perf_counter()
                cad_file = cad.read_cad_faces(path)
                read = time.perf_counter() - t0
                saved = {n: timed(cad, n, bucket) for n in ("_run_child",)}
                saved_ms = {n: timed(ms, n, bucket) for n in ("weld_parts", "densify", "clean_mesh", "mesh_surface")}
                t1 = time.perf_counter()
                piece = cad.join_faces(cad_file, pick(cad_file))
                join = time.perf_counter() - t1
                for n, f in saved.items():
                    setattr(cad, n, f)
                for n, f in saved_ms.items():
                    setattr(ms, n, f)
                runs.append((read, join, bucket, piece))
            med = lambda xs: statistics.median(xs)  # noqa: E731
            piece = runs[-1][3]
            fit = piece.fit
            rows.append(f"| {label} | {len(fit.faces)} | {fit.triangles:,} | {med([r[0] for r in runs]):.2f} | "
                        f"{med([r[1] for r in runs]):.2f} | {med([r[2]['_run_child'] for r in runs]):.2f} | "
                        f"{med([r[2]['weld_parts'] + r[2]['densify'] for r in runs]):.2f} | "
                        f"{med([r[2]['clean_mesh'] for r in runs]):.2f} | "
                        f"{med([r[2]['mesh_surface'] for r in runs]):.2f} | {fit.ctrl[0]}x{fit.ctrl[1]} | "
                        f"{100 * fit.max_deviation / fit.size:.2g} | {100 * fit.mean_deviation / fit.size:.2g} |")
    load = os.getloadavg()[0]
    text = "\n".join([
        f"load average (1 min) {load:.2f} on {os.cpu_count()} cores; median of {args.repeat} runs; seconds; "
        f"deviation in % of the joined faces' bounding-box diagonal", "",
        "| piece | faces | triangles | read file | join total | tessellate (child) | weld + densify | repair | "
        "map + fit | control net | max dev % | mean dev % |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|", *rows])
    print(text)
    if args.out:
        with open(args.out, "a", encoding="utf-8") as fh:
            fh.write(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
