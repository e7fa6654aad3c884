"""The coarse-to-fine start against the start from the drape, on every bundled surface.

    python benchmarks/multilevel.py [--nodes 2500] [--levels 1] [--repeat 1]
        [--cases octant:woven,...] [--variants plain,curve,yarn] [--out FILE]

For each (surface, material, variant) the same flattening is run from the
drape (``multilevel=0``) and from ``--levels`` coarser levels (``auto``: the
pipeline's own choice by size), alternating, ``--repeat`` times; the table
gives the median seconds, the iterations (fine + coarse), the energy, the
boundary and area errors, the uncovered share and whether the coarse-to-fine
result is the same as issue 20 asks: energy within 0.1 % (or lower),
boundary and area errors within 0.02 points, node count within 1 %.
Variants: ``plain``; ``curve``, a curve dart from the middle of the edge
u = 1 to near the centre; ``yarn``, the seed's weft row held to the plane its
drape lies in (by index).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as _dt
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from core.darts import CurveDart  # noqa: E402
from core.drape import drape  # noqa: E402
from core.energy import YarnConstraint, yarn_plane  # noqa: E402
from core.examples import example_names, load_example  # noqa: E402
from core.mesh import MATERIALS  # noqa: E402
from core.pipeline import FlattenSettings, flatten  # noqa: E402
from core.quadrature import region_area  # noqa: E402

CURVE = CurveDart(np.array([[1.0, 0.5], [0.75, 0.52], [0.45, 0.5]]), name="curve dart")


def seed_row_yarn(surface, settings: FlattenSettings) -> YarnConstraint:
    """The seed's weft row held (by index) to the plane its drape lies in."""
    d = drape(surface, settings.drape_settings(), settings.material)
    row = np.flatnonzero(d.mesh.ij[:, 0] == 0)
    row = row[np.argsort(d.mesh.ij[row, 1])]
    seed = int(np.flatnonzero((d.mesh.ij[:, 0] == 0) & (d.mesh.ij[:, 1] == 0))[0])
    normal = surface.evaluate(d.uv[[seed]]).normal[0]
    return YarnConstraint("weft", 0, yarn_plane(d.xyz[[row[0], row[-1]]], normal), 1000.0)


def settings_for(name: str, material: str, variant: str, nodes: int):
    s = load_example(name)
    st = FlattenSettings(float(np.sqrt(region_area(s) / nodes)), material=MATERIALS[material])
    if variant == "curve":
        st = dataclasses.replace(st, darts=(CURVE,))
    elif variant == "yarn":
        st = dataclasses.replace(st, yarns=(seed_row_yarn(s, st),))
    return s, st


def same(new: dict, old: dict) -> str:
    """'yes', or what differs beyond issue 20's tolerances."""
    bad = []
    if new["energy"] > old["energy"] * (1 + 1e-3):
        bad.append(f"EN {100 * (new['energy'] / old['energy'] - 1):+.2f} %")
    for key, what in (("boundary_error_pct", "boundary"), ("area_error_pct", "area")):
        if abs(new[key] - old[key]) > 0.02:
            bad.append(f"{what} {new[key] - old[key]:+.3f} pt")
    if abs(new["nodes"] - old["nodes"]) > 0.01 * old["nodes"]:
        bad.append(f"nodes {new['nodes'] - old['nodes']:+d}")
    if new["solver_status"] != "converged":
        bad.append(new["solver_status"])
    return "yes" if not bad else "**no**: " + ", ".join(bad)


def run(args) -> str:
    levels = None if args.levels == "auto" else int(args.levels)
    cases = [tuple(c.split(":")) for c in args.cases.split(",")] if args.cases else [
        (n, m) for n in example_names() for m in ("woven", "isotropic")]
    rows = []
    for name, material in cases:
        for variant in args.variants.split(","):
            s, st = settings_for(name, material, variant, args.nodes)
            flatten(s, dataclasses.replace(st, spacing=4 * st.spacing))  # warm the caches
            times = {0: [], 1: []}
            res = {}
            for _ in range(args.repeat):
                for which, lv in ((0, 0), (1, levels)):
                    t = time.perf_counter()
                    res[which] = flatten(s, st, multilevel=lv)
                    times[which].append(time.perf_counter() - t)
            old, new = res[0].metrics, res[1].metrics
            rows.append(
                f"| {name}, {material}, {variant} | {old['nodes']:,} / {new['nodes']:,} "
                f"| {np.median(times[0]):.2f} / {np.median(times[1]):.2f} "
                f"| {old['iterations']} / {new['iterations'] - new['coarse_iterations']}+{new['coarse_iterations']} "
                f"| {old['energy']:.7g} / {new['energy']:.7g} "
                f"| {old['boundary_error_pct']:.3f} / {new['boundary_error_pct']:.3f} "
                f"| {old['area_error_pct']:.3f} / {new['area_error_pct']:.3f} "
                f"| {old.get('uncovered_pct', 0.0):.3f} / {new.get('uncovered_pct', 0.0):.3f} | {same(new, old)} |")
            print(rows[-1], flush=True)
    head = (f"`benchmarks/multilevel.py --nodes {args.nodes} --levels {args.levels} --repeat {args.repeat}`, "
            f"{_dt.date.today()}, {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
            f"load average {os.getloadavg()[0]:.1f} at the end. Each cell: from the drape / coarse-to-fine; "
            "iterations of the coarse-to-fine run: fine + all coarser levels'.\n\n"
            "| case | nodes | seconds (median) | iterations | EN | boundary error % | area error % | uncovered % "
            "| same result |\n|---|---|---|---|---|---|---|---|---|\n")
    return head + "\n".join(rows) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--nodes", type=int, default=2_500)
    p.add_argument("--levels", default="1", help="coarser levels, or 'auto' (the pipeline's choice)")
    p.add_argument("--repeat", type=int, default=1)
    p.add_argument("--cases", default="", help="surface:material,... (default: every bundled surface, both)")
    p.add_argument("--variants", default="plain,curve,yarn")
    p.add_argument("--out", type=Path)
    args = p.parse_args(argv)
    text = run(args)
    if args.out:
        with open(args.out, "a") as f:
            f.write(f"\n## {args.nodes:,} nodes, levels {args.levels}\n\n" + text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
