"""The paper's Table 3 comparison: our method against the planar energy method
(Wang, Smith and Yuen 2002, the paper's reference [7], ``core.planar``).

    python benchmarks/planar_compare.py [--quick] [--out benchmarks/results/planar_compare.md]

On the garment panel without and with the collar dart (the paper's Table 3
cases), and on the sphere octant and the saddle: our method with woven
(500:500:1) and isotropic (100:100:100) cloth (``core.pipeline.flatten``),
the planar method's unfolding alone (triangles laid flat one by one, before
any relaxation) and the planar method relaxed to convergence. Boundary and
area errors use the same definitions and the same exact 3D references for
both methods. Prints markdown tables and writes them to the output file.
Timings are of this machine; run it on an idle machine.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import os
import platform
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from core.darts import PlaneDart
from core.examples import load_example
from core.mesh import MATERIALS
from core.pipeline import FlattenSettings, flatten
from core.planar import PlanarSettings, flatten_planar
from core.quadrature import region_area

COLLAR = PlaneDart((1.0, 0.0, 0.0, -0.02), (-1, 1, 0.42, 1, -1, 1), name="collar dart")
PAPER_TABLE3 = {"garment": (13.52, 4.10), "garment, collar dart": (5.32, 3.84)}


def table(headers, rows) -> str:
    out = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def cases(quick: bool):
    g = 0.02 if quick else 0.01
    return [("garment", "garment", g, ()), ("garment, collar dart", "garment", g, (COLLAR,)),
            ("octant", "octant", 0.05 if quick else 0.025, ()), ("saddle", "saddle", 0.1 if quick else 0.05, ())]


def run_case(label, name, h, darts):
    """Rows of one surface; also the numbers the verdict needs."""
    s = load_example(name)
    A3 = region_area(s)
    rows, got = [], {}
    if label in PAPER_TABLE3:
        be, ae = PAPER_TABLE3[label]
        rows.append([label, "planar [7], the paper's Table 3", "", f"{be:.2f}", f"{ae:.2f}", "", "", "", ""])
    for mat in ("woven", "isotropic"):
        r = flatten(s, FlattenSettings(h, material=MATERIALS[mat], darts=darts), area=A3)
        m = r.metrics
        got[mat] = m
        strain = max(m["max_thread_strain_pct"], m["max_diag_strain_pct"])
        rows.append([label, f"ours, {mat}", m["nodes"], f"{m['boundary_error_signed_pct']:+.2f}",
                     f"{m['area_error_signed_pct']:+.2f}", f"{strain:.2f} (threads {m['max_thread_strain_pct']:.2f})",
                     "", f"{m['seconds']:.2f}", m["solver_status"]])
    for solver, what in (("none", "planar [7], unfolding only"), ("lm", "planar [7], relaxed")):
        r = flatten_planar(s, PlanarSettings(h, darts=darts, solver=solver), area=A3)
        m = r.metrics
        got[solver] = m
        rows.append([label, what, m["nodes"], f"{m['boundary_error_signed_pct']:+.2f}",
                     f"{m['area_error_signed_pct']:+.2f}", f"{m['max_edge_strain_pct']:.2f}",
                     m["flipped_triangles"], f"{m['seconds']:.2f}",
                     f"{m['iterations']} iterations, {m['solver_status']}" if solver != "none" else
                     f"energy {m['energy']:.3g}"])
    return rows, got


def verdict(results) -> str:
    """Say, from the numbers, whether our errors are lower than the planar method's."""
    lines = []
    for label in ("garment", "garment, collar dart"):
        got = results[label]
        pl = got["lm"]
        for mat in ("woven", "isotropic"):
            m = got[mat]
            parts = []
            for key, word in (("boundary_error_pct", "boundary"), ("area_error_pct", "area")):
                ours, theirs = m[key], pl[key]
                parts.append(f"{word} {ours:.2f} % vs {theirs:.2f} % ({'lower' if ours < theirs else 'NOT lower'})")
            lines.append(f"- {label}, ours {mat} against the relaxed planar method: " + "; ".join(parts) + ".")
    ok = all(results[lb][mat][k] < results[lb]["lm"][k] for lb in ("garment", "garment, collar dart")
             for mat in ("woven",) for k in ("boundary_error_pct", "area_error_pct"))
    head = ("**Target (issue 8): our boundary and area errors lower than the planar method's on the garment.** "
            + ("Met by woven cloth in both garment cases." if ok else
               "Not met in every case: see the lines marked NOT lower.") + "\n\n")
    notes = []
    for label, (be, ae) in PAPER_TABLE3.items():
        u, r = results[label]["none"], results[label]["lm"]
        notes.append(f"- {label}: the paper's Table 3 gives the planar method {be:.2f} % / {ae:.2f} %; here it gives "
                     f"{r['boundary_error_pct']:.2f} % / {r['area_error_pct']:.2f} % relaxed and "
                     f"{u['boundary_error_pct']:.2f} % / {u['area_error_pct']:.2f} % from the unfolding alone.")
    return (head + "\n".join(lines) + "\n\nThe paper's garment is not ours (its surface is not published; ours is "
            "a synthetic bodice panel), so its Table 3 numbers are not reproduced, only compared:\n\n"
            + "\n".join(notes))


def convergence(quick: bool) -> str:
    """The planar method on the garment at three spacings: its errors are not a
    discretisation artefact."""
    s = load_example("garment")
    A3 = region_area(s)
    rows = []
    for h in ((0.04, 0.02) if quick else (0.02, 0.01, 0.005)):
        for label, darts in (("garment", ()), ("garment, collar dart", (COLLAR,))):
            m = flatten_planar(s, PlanarSettings(h, darts=darts), area=A3).metrics
            rows.append([label, h, m["nodes"], f"{m['boundary_error_signed_pct']:+.3f}",
                         f"{m['area_error_signed_pct']:+.3f}", f"{m['max_edge_strain_pct']:.2f}",
                         f"{m['seconds']:.2f}"])
    head = ["case", "spacing m", "nodes", "boundary err % (signed)", "area err % (signed)", "max edge strain %",
            "seconds"]
    return "### The planar method on the garment at three spacings\n\n" + table(head, rows)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="coarser meshes (a smoke run)")
    p.add_argument("--out", default=str(Path(__file__).parent / "results" / "planar_compare.md"))
    args = p.parse_args(argv)
    head = (f"# flatweave against the planar energy method (the paper's Table 3)\n\n{_dt.date.today()} on "
            f"{platform.node()} ({os.cpu_count()} cores, {platform.machine()}, Python {platform.python_version()})\n")
    rows, results = [], {}
    for label, name, h, darts in cases(args.quick):
        r, got = run_case(label, name, h, darts)
        rows += r
        results[label] = got
    spacings = ", ".join(f"{label} {h}" for label, _, h, _ in cases(args.quick))
    hdr = ["case", "method", "nodes", "boundary err % (signed)", "area err % (signed)", "max strain %",
           "flipped triangles", "seconds", "solver"]
    main_table = (f"### Table 3, extended (spacing in m: {spacings}; the planar method's edges are that long, "
                  "our lattice springs too)\n\n" + table(hdr, rows) + "\n\n"
                  "Boundary error = 100 (L2 - L3) / L3 with L3 the exact boundary length of the surface and L2 "
                  "the pattern outline's perimeter (dart legs excluded); area error likewise. Max strain: ours "
                  "over all springs (thread springs in brackets), the planar method's over all triangle edges "
                  "(2D length against 3D length). 'Unfolding only' is the planar method before its relaxation.")
    parts = [head, main_table, verdict(results), convergence(args.quick)]
    text = "\n\n".join(parts) + "\n"
    print(text)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
