"""The cut plan's nesting (issue 43), measured by ``benchmarks/suite.py``:

- case ``nest_esicup``: the ESICUP garment instances shirts and trousers
  (``benchmarks/data/esicup``) nested through ``flatweave-cli nest`` (a child
  process, as a user runs it) and by spyrrow called directly on the same
  instance, with the same time budget (the size), seed and threads, one after
  the other: the utilisation each reaches, and the headline ``loss_pp``, how
  many percentage points the command's marker is below the direct call's at
  worst (what the integration, with its outline conversion, loses); and each
  against sparrow's published records (their ``record_*`` densities);
- case ``nest_vs_shelf``: our own multi-piece projects, the bundled 24-ply dome
  laminate (solved; a roll 2,500 mm wide, as no narrower one holds its widest
  ply unspliced) and the garment front split into four panels, 20 of each (a
  roll 1,500 mm wide) and a kit of the bundled examples' patterns (cone, octant,
  saddle, dome, garment; 3 of each on a roll 3,000 mm wide), nested by ``nest`` against
  a shelf packer of bounding boxes
  (pieces by falling length along the roll, stacked across it shelf by shelf):
  the utilisation each reaches, and the headline ``gain_pp``, nest's gain at
  worst; the laminate's wall time is ``laminate_s``;
- case ``splice_laminate``: the dome laminate's plies on their 1,270 mm rolls, every
  one wider: the seconds ``splice_items`` takes to splice them (the items made first).
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "benchmarks" / "data" / "esicup"
RECORDS = {"shirts": 59.393, "trousers": 235.172}  # sparrow's best known marker lengths (its repository's records)
WORKERS = 2


def _area(shape) -> float:
    p = np.asarray(shape, dtype=float)
    return 0.5 * abs(float(np.dot(p[:, 0], np.roll(p[:, 1], -1)) - np.dot(p[:, 1], np.roll(p[:, 0], -1))))


def direct(doc: dict, seconds: int, seed: int = 0) -> float:
    """spyrrow on the instance as it is: the utilisation (its density)."""
    import spyrrow

    items = [spyrrow.Item(str(i["id"]), [tuple(p) for p in i["shape"]["data"]], i["demand"],
                          i.get("allowed_orientations")) for i in doc["items"]]
    inst = spyrrow.StripPackingInstance(doc["name"], doc["strip_height"], items)
    cfg = spyrrow.StripPackingConfig(early_termination=True, total_computation_time=seconds, num_workers=WORKERS,
                                     seed=seed)
    return float(inst.solve(cfg).density)


def _cli(args: list[str]) -> tuple[float, float, float]:
    """``python -m flatweave nest ...`` in a child: (utilisation, length mm, wall seconds) of its last marker."""
    t0 = time.perf_counter()
    run = subprocess.run([sys.executable, "-m", "flatweave", "nest", *args, "--quiet"], capture_output=True,
                         text=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})
    wall = time.perf_counter() - t0
    if run.returncode != 0:
        raise RuntimeError(run.stderr.strip())
    found = re.findall(r"marker ([0-9.]+) mm long .* utilisation ([0-9.]+) %", run.stderr)
    lengths = [float(a) for a, _ in found]
    utils = [float(b) / 100.0 for _, b in found]
    return min(utils), max(lengths), wall


def measure_esicup(seconds: int) -> dict:
    out = {}
    for name in ("shirts", "trousers"):
        path = DATA / f"{name}.json"
        doc = json.loads(path.read_text())
        ours, _, _ = _cli([str(path), "--time-limit", str(seconds), "--seed", "0"])
        theirs = direct(doc, seconds)
        area = sum(_area(i["shape"]["data"]) * i["demand"] for i in doc["items"])
        out[f"{name}_nest"] = ours
        out[f"{name}_direct"] = theirs
        out[f"record_{name}"] = area / (RECORDS[name] * doc["strip_height"])
    out["loss_pp"] = max(100.0 * (out[f"{n}_direct"] - out[f"{n}_nest"]) for n in ("shirts", "trousers"))
    return out


def shelf(outlines, width: float) -> float:
    """A shelf packer of bounding boxes: each outline's box (as given: its grain along x), by falling length
    along the roll, stacked across it (y) until the next would pass the width, then a new shelf starts after
    the longest of the last; the utilisation (outlines' area over the roll used)."""
    boxes = sorted(((float(np.ptp(o[:, 0])), float(np.ptp(o[:, 1])), _area(o)) for o in outlines), reverse=True)
    x = shelf_len = y = 0.0
    for length, across, _ in boxes:
        if y + across > width:
            x, y, shelf_len = x + shelf_len, 0.0, 0.0
        y += across
        shelf_len = max(shelf_len, length)
    used = (x + shelf_len) * width
    return sum(b[2] for b in boxes) / used


def _outlines(project, seam_mm: float, copies: int):
    """Every copy's cut outline (mm) of a project's solved pieces, turned with its grain along x."""
    from flatweave.document.cutplan import project_items

    items, _ = project_items(project, "p", seam_mm, copies)
    out = []
    for it in items:
        a = np.radians(-it.item.grain_deg)
        c, s = np.cos(a), np.sin(a)
        o = it.item.outline
        turned = np.column_stack([c * o[:, 0] - s * o[:, 1], s * o[:, 0] + c * o[:, 1]])
        out += [turned] * it.item.quantity
    return out


def measure_vs_shelf(seconds: int) -> dict:
    from flatweave.document import sewing as S
    from flatweave.document.matching import solve_all
    from flatweave.document.project import load_project, new_project, save_project
    from flatweave.reading.examples import load_example

    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        lam = tmp / "dome-laminate.flatweave"
        subprocess.run([sys.executable, "-m", "flatweave", "solve", "dome-laminate", "--quiet", "--out", str(lam)],
                       check=True, capture_output=True, cwd=tmp, env={**os.environ, "PYTHONPATH": str(ROOT)})
        util, _, wall = _cli([str(lam), "--roll-width", "2500", "--time-limit", str(seconds)])
        out["laminate_nest"], out["laminate_s"] = util, wall
        out["laminate_shelf"] = shelf(_outlines(load_project(lam), 0.0, 1), 2500.0)
        p = new_project(load_example("garment"), "bodice", "garment", spacing=0.02)
        p = S.add_seam(p, S.SeamLine("centre", np.array([[0.5, -0.05], [0.5, 1.05]])))
        p = S.add_seam(p, S.SeamLine("waist", np.array([[-0.05, 0.45], [1.05, 0.55]])))
        p, _, _ = solve_all(p, workers=WORKERS)
        bodice = save_project(p, tmp / "bodice.flatweave")
        util, _, _ = _cli([f"{bodice}:20", "--roll-width", "1500", "--seam-allowance", "10", "--time-limit",
                           str(seconds)])
        out["panels_nest"] = util
        out["panels_shelf"] = shelf(_outlines(p, 10.0, 20), 1500.0)
        kit = save_project(examples_kit(), tmp / "kit.flatweave")
        util, _, _ = _cli([f"{kit}:3", "--roll-width", "3000", "--time-limit", str(seconds)])
        out["kit_nest"] = util
        out["kit_shelf"] = shelf(_outlines(load_project(kit), 0.0, 3), 3000.0)
    out["gain_pp"] = min(100.0 * (out[f"{n}_nest"] - out[f"{n}_shelf"]) for n in ("laminate", "panels", "kit"))
    return out


def examples_kit():
    """A project of a piece of each bundled example but the half cylinder (a rectangle): the cone's
    annulus sector, the octant, the saddle, the dome, the garment front; woven, solved."""
    from flatweave.document import pieces as P
    from flatweave.document.project import new_project
    from flatweave.document.solving import solve_pieces
    from flatweave.method.settings import FlattenSettings
    from flatweave.reading.examples import load_example

    names = ("cone", "octant", "saddle", "dome", "garment")
    p = new_project(load_example(names[0]), "kit", names[0], spacing=0.05)
    for name in names[1:]:
        surface = load_example(name)
        p = P.add(p, name, FlattenSettings(spacing=0.05), surface=surface, source=name)
    p, _ = solve_pieces(p, workers=WORKERS)
    return p


def measure_splices(plies: int) -> dict:
    """The bundled dome laminate (solved) on its materials' 1,270 mm rolls: the first ``plies`` plies'
    items made and spliced as nest splices them (every ply is wider than the roll); the seconds."""
    from flatweave.document import pieces as P
    from flatweave.document.cutplan import project_items, splice_items
    from flatweave.document.project import load_project

    with tempfile.TemporaryDirectory() as tmp:
        lam = Path(tmp) / "dome-laminate.flatweave"
        subprocess.run([sys.executable, "-m", "flatweave", "solve", "dome-laminate", "--quiet", "--out", str(lam)],
                       check=True, capture_output=True, cwd=tmp, env={**os.environ, "PYTHONPATH": str(ROOT)})
        project = load_project(lam)
    names = [p.name for p in project.pieces][plies:]
    for name in names:
        project = P.remove(project, name)
    items, _ = project_items(project, "lam", 0.0)
    t0 = time.perf_counter()
    parts, reports = splice_items(items, 1270.0, 25.0)
    seconds = time.perf_counter() - t0
    return {"seconds": seconds, "spliced": float(len(reports)), "parts": float(len(parts))}
