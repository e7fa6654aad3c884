"""The headless CLI: ``python -m flatweave``."""

import base64
import json
import subprocess
import sys
import zlib

import numpy as np
import pytest

from flatweave.cli import main
from flatweave.reading.examples import example_path
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.geometry.surface_json import save_surface
from tests.helpers import SurfaceFault

REQUIRED_METRICS = {"energy", "max_thread_strain_pct", "max_shear_deg", "mean_shear_deg", "nodes", "springs",
                    "seconds", "boundary_error_pct", "area_error_pct", "iterations", "energy_evaluations"}


def run_cli(*args):
    """Run ``python -m flatweave`` in a subprocess: (exit status, stdout, stderr)."""
    p = subprocess.run([sys.executable, "-m", "flatweave", *args], capture_output=True, text=True, timeout=300)
    return p.returncode, p.stdout, p.stderr


def test_flatten_drape_only_writes_the_documented_result(tmp_path):
    out = tmp_path / "r.json"
    assert main(["flatten", str(example_path("octant")), "--spacing", "0.1", "--material", "woven",
                 "--solver", "none", "--quiet", "--out", str(out)]) == 0
    r = json.loads(out.read_text())
    assert REQUIRED_METRICS <= set(r["metrics"]) and r["version"] == 2
    n, m = r["metrics"]["nodes"], r["metrics"]["springs"]
    # version 2's arrays, decoded with numpy, zlib and base64 alone (as the module docstring says)
    a = {f"{group}.{key}": np.frombuffer(zlib.decompress(base64.b64decode(v["zlib_base64"])), v["dtype"])
         .reshape(v["shape"]) for group in ("nodes", "springs", "cells") for key, v in r[group].items()
         if isinstance(v, dict)}
    assert [a[f"nodes.{k}"].shape for k in ("ij", "uv", "xyz", "xy")] == [(n, 2), (n, 2), (n, 3), (n, 2)]
    for key in ("ends", "kind", "rest", "length", "strain"):
        assert len(a[f"springs.{key}"]) == m
    kind = np.array(r["springs"]["kind_names"])[a["springs.kind"]]
    assert set(kind) == {"weft", "warp", "diag"}
    assert a["cells.corners"].shape[0] == len(a["cells.shear_deg"]) > 0 and a["cells.corners"].dtype == np.int32
    assert r["metrics"]["iterations"] == 0
    strain = a["springs.strain"].astype(float)
    thread = kind != "diag"
    # the drape lays its threads' chords at their lattice length 0.1, so on the unit sphere the
    # threads (great-circle arcs) are longer: arc / chord - 1 = asin(0.05) / 0.05 - 1 (a solve takes it out)
    assert strain[thread] == pytest.approx(np.arcsin(0.05) / 0.05 - 1, rel=1e-5)  # float32: 7 digits
    assert len(r["pattern"]["outline"]) == len(r["pattern"]["outline3d"]) > 100


@pytest.mark.slow
def test_flatten_any_geomdl_surface(tmp_path):
    # a surface that is not one of the examples: a random bicubic bump, 9 x 7
    rng = np.random.default_rng(4)
    u, v = np.meshgrid(np.linspace(0, 2, 9), np.linspace(0, 1.5, 7), indexing="ij")
    P = np.stack([u, v, 0.2 * rng.random(u.shape)], axis=-1)
    ku = [0, 0, 0, 0, .2, .4, .6, .8, .9, 1, 1, 1, 1]
    kv = [0, 0, 0, 0, .3, .5, .7, 1, 1, 1, 1]
    path = tmp_path / "bump.json"
    save_surface(NurbsSurface(3, 3, ku, kv, P), path)
    out = tmp_path / "r.json"
    code, _, err = run_cli("flatten", str(path), "--spacing", "0.1", "--material", "isotropic",
                           "--seed", "0.4,0.6", "--angle", "30", "--out", str(out))
    assert code == 0, err
    r = json.loads(out.read_text())
    assert r["metrics"]["solver_status"] == "converged" and r["metrics"]["nodes"] > 200
    assert r["settings"]["seed"] == [0.4, 0.6] and r["settings"]["angle_deg"] == 30


@pytest.mark.slow
def test_example_name_warm_start_and_yarn(tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    assert main(["flatten", "octant", "--spacing", "0.1", "--quiet", "--out", str(a)]) == 0
    assert main(["flatten", "octant", "--spacing", "0.1", "--quiet", "--warm-start", str(a),
                 "--yarn", "warp:0", "--yarn-plane", "1,-1,0,0", "--yarn-k", "100", "--out", str(b)]) == 0
    rb = json.loads(b.read_text())
    assert rb["drape"].get("warm_start") is True
    assert rb["settings"]["yarns"] == [{"kind": "warp", "index": 0, "plane": [1.0, -1.0, 0.0, 0.0], "k": 100.0}]


@pytest.mark.slow
@pytest.mark.parametrize("args, words", [
    (["flatten", "{bad}", "--spacing", "0.1"], ["weights"]),
    (["flatten", "{octant}", "--spacing", "-1"], ["spacing"]),
    (["flatten", "{octant}", "--spacing", "0.1", "--material", "silk"], ["material"]),
    (["flatten", "{octant}", "--spacing", "0.1", "--seed", "0.5"], ["seed"]),
    (["flatten", "{octant}", "--spacing", "0.1", "--yarn", "warp:x", "--yarn-plane", "1,0,0,0"], ["yarn"]),
    (["flatten", "{octant}", "--spacing", "0.1", "--yarn", "warp:1"], ["--yarn-plane"]),
    (["flatten", "nowhere.json", "--spacing", "0.1"], ["nowhere.json"]),
    (["flatten", "teapot", "--spacing", "0.1"], ["teapot", "example"]),
    (["flatten", "{octant}", "--spacing", "0.0001", "--max-nodes", "1000"], ["nodes", "spacing"]),
    (["flatten", "{octant}", "--spacing", "0.1", "--warm-start", "{bad}"], ["warm-start"]),
])
def test_bad_input_is_one_line_and_status_2(tmp_path, args, words):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"shape": {"type": "surface", "count": 1, "data": [{
        "type": "spline", "rational": True, "degree_u": 1, "degree_v": 1,
        "knotvector_u": [0, 0, 1, 1], "knotvector_v": [0, 0, 1, 1], "size_u": 2, "size_v": 2,
        "control_points": {"points": [[0, 0, 0], [0, 1, 0], [1, 0, 0], [1, 1, 1]],
                           "weights": [1, 1, -1, 1]}}]}}))
    subst = {"{bad}": str(bad), "{octant}": str(example_path("octant"))}
    args = [subst.get(a, a) for a in args] + ["--out", str(tmp_path / "out.json")]
    code, out, err = run_cli(*args)
    assert code == 2
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("flatweave: error:"), err
    assert "Traceback" not in err
    for w in words:
        assert w.lower() in lines[0].lower()
    assert not (tmp_path / "out.json").exists()


@pytest.mark.slow
def test_unwritable_output_is_a_clean_error(tmp_path):
    code, _, err = run_cli("flatten", "octant", "--spacing", "0.2", "--out", str(tmp_path / "no" / "r.json"))
    assert code == 2 and "does not exist" in err and "Traceback" not in err


@pytest.mark.slow
def test_info_and_examples():
    code, out, _ = run_cli("info", "octant")
    assert code == 0 and "area 1.570796327" in out and "boundary length 4.71238898" in out
    code, out, _ = run_cli("examples")
    assert code == 0 and all(name in out for name in ("octant", "cone", "garment", "saddle", "dome"))


def test_export_every_format_from_the_cli(tmp_path):
    """The octant with a dart, to every format in one run (as in the README and docs/guide/exports.md)."""
    import ezdxf

    paths = [tmp_path / f"octant{s}" for s in (".dxf", ".svg", ".pdf", ".vtp", ".obj")]
    args = ["flatten", "octant", "--spacing", "0.1", "--plane-dart", "1,-1,0,0:-2,2,-2,2,-2,0.55",
            "--seam-allowance", "15", "--units", "cm", "--paper", "letter", "--quiet"]
    for p in paths:
        args += ["--export", str(p)]
    assert main(args) == 0
    assert all(p.stat().st_size > 0 for p in paths)
    doc = ezdxf.readfile(paths[0])
    texts = " ".join(e.dxf.text for b in doc.blocks for e in b if e.dxftype() == "TEXT")
    assert "seam allowance 15 mm" in texts and "model in cm" in texts and "octant" in texts


@pytest.mark.slow
@pytest.mark.parametrize("args, words", [
    (["--export", "{tmp}/p.xyz"], ["unknown format", ".xyz"]),
    (["--export", "{tmp}/missing/p.dxf"], ["does not exist"]),
    (["--export", "{tmp}/p.dxf", "--seam-allowance", "-3"], ["argument --seam-allowance", "out of range"]),
    ([], ["nothing to write"]),
])
def test_bad_exports_fail_before_the_solve(tmp_path, args, words):
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    code, out, err = run_cli("flatten", "octant", "--spacing", "0.01", *args)  # a long solve if it ran
    assert code == 2
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("flatweave: error:"), err
    assert all(w in lines[0] for w in words)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("method, expected", [
    ("spring", "flatweave: error: the energy became NaN at iteration 4 (the surface evaluation returned a "
               "non-finite point at 1 node); the solve stopped and nothing was changed"),
    ("planar", "flatweave: error: the surface evaluation returned a non-finite derivative at 1 of 16,705 "
               "derivative samples while triangulating; the solve stopped and nothing was changed")])
def test_a_nan_in_the_solve_is_one_line_and_status_2(tmp_path, monkeypatch, capsys, method, expected):
    # in this process, so the surface can be made to fail: after iteration 3 of
    # the spring method's solve, from the start of the planar method's triangulation
    import flatweave.method.pipeline

    fault = SurfaceFault(monkeypatch)
    if method == "spring":
        monkeypatch.setattr(flatweave.method.pipeline, "iterate", fault.arm_after(3, flatweave.method.pipeline.iterate))
    else:
        fault.armed = True
    out = tmp_path / "r.json"
    code = main(["flatten", "octant", "--spacing", "0.1", "--method", method, "--quiet", "--out", str(out)])
    captured = capsys.readouterr()
    assert code == 2 and captured.out == ""
    assert captured.err.splitlines() == [expected]
    assert not out.exists() and fault.hits >= 1


@pytest.mark.slow
@pytest.mark.parametrize("name, spacing, words", [
    ("octant", "0.025", "of them on 1 coarser level"),  # carried from a quarter-size solve
    ("saddle", "0.045", "of them on a coarser drape that held"),  # the coarse solve kept every node
    ("octant", "0.1", None),  # too small to start coarse
])
def test_the_summary_says_where_the_iterations_were_spent(tmp_path, capsys, name, spacing, words):
    assert main(["flatten", name, "--spacing", spacing, "--out", str(tmp_path / "r.json")]) == 0
    # the summary line, not a progress line ("  iteration ...") a slow machine prints first
    (line,) = [s for s in capsys.readouterr().err.splitlines() if " springs, energy " in s]
    # the woven saddle's shear passes the 15 deg warning angle: its status says "with warnings"
    assert "iterations (converged)" in line or "iterations (converged, with warnings)" in line
    if words is None:
        assert "of them on" not in line
    else:
        assert words in line
