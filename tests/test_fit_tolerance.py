"""A mesh fitted to a stated tolerance (``--fit-tolerance``, issue 40): the
fitted surface is refined until no vertex is farther than the tolerance, or a
one-line refusal says why not (noise, detail finer than the net).

Truth from outside the code: the meshes sample closed-form shapes, so the
deviation a fit reaches is measured against vertices that lie on a smooth
surface (or, with noise added here, do not)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
import trimesh

from flatweave.errors import SettingsError
from flatweave.geometry.meshfit import FitTolerance, MeshFit, mesh_surface
from tests.test_meshsurf import grid_mesh


def bumps(u, v):
    """A 1 x 1 sheet with a few bumps (smooth, detail a default net follows only roughly)."""
    return np.stack([u, v, 0.06 * np.sin(5 * np.pi * u) * np.sin(4 * np.pi * v) + 0.1 * u * u], 1)


@pytest.fixture(scope="module")
def sheet():
    return grid_mesh(bumps, 90, 90)


def test_a_stated_tolerance_is_met_and_kept_in_the_fit_record(sheet):
    V, F = sheet
    default = mesh_surface(V, F)
    size = default.fit.size
    assert default.fit.tolerance is None
    for frac in (2e-3, 2e-4, 1e-4):
        piece = mesh_surface(V, F, tolerance=frac * size)
        assert piece.fit.max_deviation <= frac * size
        assert piece.fit.tolerance == pytest.approx(frac * size)
        assert np.max(piece.deviation) == pytest.approx(piece.fit.max_deviation)
    # a tighter tolerance takes a finer net; the record survives its round trip
    loose, tight = mesh_surface(V, F, tolerance=2e-3 * size), mesh_surface(V, F, tolerance=1e-4 * size)
    assert np.prod(tight.fit.ctrl) > np.prod(loose.fit.ctrl)
    assert MeshFit.from_dict(json.loads(json.dumps(tight.fit.to_dict()))) == tight.fit


def test_noise_beyond_the_tolerance_is_refused_in_one_line_naming_it(sheet):
    V, F = sheet
    rng = np.random.default_rng(2)
    noisy = V.copy()
    noisy[:, 2] += rng.normal(scale=2e-3, size=len(V))  # a scanner's noise, 0.14 % of the size
    size = float(np.linalg.norm(np.ptp(V, axis=0)))
    with pytest.raises(FitTolerance) as err:
        mesh_surface(noisy, F, name="noisy.stl", tolerance=1e-4 * size)
    msg = str(err.value)
    assert msg.startswith("noisy.stl: the surface fitted to it is up to ") and "\n" not in msg
    assert "noise" in msg and "over the fit tolerance" in msg
    # the same scan at a tolerance above its noise is met
    assert mesh_surface(noisy, F, tolerance=5e-3 * size).fit.max_deviation <= 5e-3 * size


def test_detail_finer_than_the_vertices_pin_is_said_so():
    """A coarse sampling of a shape with more ripples than control points its vertices can pin."""
    V, F = grid_mesh(lambda u, v: np.stack([u, v, 0.02 * np.sin(9 * np.pi * u) * np.sin(9 * np.pi * v)], 1), 16, 16)
    with pytest.raises(FitTolerance, match="finer than"):
        mesh_surface(V, F, name="coarse.stl", tolerance=1e-7)


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf")])
def test_a_tolerance_that_is_not_a_positive_length_is_refused(sheet, bad):
    V, F = sheet
    with pytest.raises(SettingsError, match="fit tolerance must be a positive number"):
        mesh_surface(V, F, tolerance=bad)


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "flatweave", *map(str, args)], capture_output=True, text=True,
                          timeout=600)


@pytest.mark.slow
def test_the_cli_fits_to_the_tolerance_or_exits_2_in_one_line(sheet, tmp_path):
    V, F = sheet
    path = tmp_path / "bumps.stl"
    trimesh.Trimesh(V * 100, F, process=False).export(path)  # 141 units across
    out = tmp_path / "r.json"
    p = _cli("flatten", path, "--spacing", "5", "--fit-tolerance", "0.01", "--out", out, "--quiet")
    assert p.returncode == 0, p.stderr
    d = json.loads(out.read_text())
    assert d["metrics"]["fit_max_deviation"] <= 0.01
    p = _cli("info", path, "--fit-tolerance", "0.01", "--json")
    info = json.loads(p.stdout)
    assert info["fit"]["tolerance"] == 0.01 and info["fit_max_deviation"] <= 0.01
    p = _cli("info", path, "--json")  # the default: no tolerance stated, none recorded
    assert "tolerance" not in json.loads(p.stdout)["fit"]
    for args, says in ((["--fit-tolerance", "1e-9"], "over the fit tolerance 1e-09"),
                       (["--fit-tolerance", "-2"], "argument --fit-tolerance: '-2' is out of range")):
        p = _cli("flatten", path, "--spacing", "5", *args, "--out", out)
        assert p.returncode == 2 and says in p.stderr and p.stderr.count("\n") == 1, p.stderr
    p = _cli("flatten", "octant", "--spacing", "0.1", "--fit-tolerance", "0.01", "--out", out)
    assert p.returncode == 2 and "--fit-tolerance is for meshes" in p.stderr and p.stderr.count("\n") == 1
