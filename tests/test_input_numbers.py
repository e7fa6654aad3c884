"""Every number that comes from outside is finite and within a stated range for what it means
(issue 45, item 2): an option's value is refused by its type, naming the option and the range;
a spacing below a millionth of the piece's size, an offset beyond the surface's size, a curve
dart's tolerance that is not a positive number are refused once the piece is read. Each in one
line, exit 2, nothing written. Coefficients as large as 1e308 that mean an ordinary plane
are that plane."""

from __future__ import annotations

import json

import numpy as np
import pytest

from flatweave.cli import main
from flatweave.errors import SettingsError
from flatweave.method.darts import PlaneDart
from flatweave.method.energy import YarnConstraint
from flatweave.reading.examples import load_example

LONG_NAME = "a" * 300


@pytest.mark.parametrize("args, words", [
    (["--region-offset", "1e308"], "argument --region-offset: '1e308' is out of range: a number from -1e+15 to 1e+15"),
    (["--auto-darts", "1000000"], "argument --auto-darts: '1000000' is out of range: a whole number from 0 to 100"),
    (["--seam-allowance", "1e308"], "argument --seam-allowance: '1e308' is out of range: a number from 0 to 500"),
    (["--max-iter", "-1"], "argument --max-iter: '-1' is out of range: a whole number from 0 to 1e+07"),
    (["--tol", "nan"], "argument --tol: 'nan' is out of range: a number above 0 and at most 1"),
    (["--spacing-warp", "inf"], "argument --spacing-warp: 'inf' is out of range"),
    (["--max-seconds", "0"], "argument --max-seconds: '0' is out of range: a number above 0"),
    (["--yarn-k", "-5"], "argument --yarn-k: '-5' is out of range"),
    (["--max-nodes", "0"], "argument --max-nodes: '0' is out of range"),
    (["--face", "99999999999"], "argument --face: '99999999999' is out of range"),
    (["--angle", "1e308"], "argument --angle: '1e308' is out of range"),
])
def test_an_option_out_of_its_range_is_one_line_naming_it_and_the_range(tmp_path, capsys, args, words):
    out = tmp_path / "r.json"
    with pytest.raises(SystemExit) as e:
        main(["flatten", "octant", "--spacing", "0.1", *args, "--out", str(out)])
    assert e.value.code == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith("flatweave: error: flatten: ") and words in line and line.endswith("--help"), line
    assert not out.exists()


@pytest.mark.parametrize("argv, words", [
    (["sweep", "octant", "--spacing", "0.1", "--angles", "100000"], "argument --angles: '100000' is out of range"),
    (["sweep", "octant", "--spacing", "0.1", "--lock-angle", "95"], "argument --lock-angle: '95' is out of range"),
    (["sweep", "octant", "--spacing", "0.1", "--seeds", "0"], "argument --seeds: '0' is out of range"),
    (["solve", "dome-laminate", "--workers", "1000"], "argument --workers: '1000' is out of range"),
    (["solve", "dome-laminate", "--seam-allowance", "-1"], "argument --seam-allowance: '-1' is out of range"),
])
def test_the_other_commands_options_too(capsys, argv, words):
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert words in line and line.endswith("--help"), line


@pytest.mark.parametrize("args, words", [
    (["--spacing", "1e-300"], "the spacing 1e-300 is below a millionth of the piece's size"),
    (["--spacing", "0.1", "--spacing-warp", "1e-9"], "the spacing 1e-09 is below a millionth"),
    (["--spacing", "0.1", "--region-offset", "5"], "the region offset must be a distance from -1.732 to 1.732"),
])
def test_numbers_that_make_no_sense_for_the_piece_are_refused_once_it_is_read(tmp_path, capsys, args, words):
    out = tmp_path / "r.json"
    assert main(["flatten", "octant", *args, "--out", str(out)]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith("flatweave: error: ") and words in line, line
    assert not out.exists()


@pytest.mark.parametrize("tolerance", ["x", -1.0, 0, 1e999, True, [1]])
def test_a_curve_darts_tolerance_that_is_not_a_positive_number_is_one_line(tmp_path, capsys, tolerance):
    dart = tmp_path / "dart.json"
    text = json.dumps({"points": [[0.2, 0.2, 1.0], [0.6, 0.6, 1.0]], "view_direction": [0, 0, -1],
                       "tolerance": tolerance}).replace("Infinity", "1e999")
    dart.write_text(text)
    out = tmp_path / "r.json"
    assert main(["flatten", "octant", "--spacing", "0.1", "--curve-dart", str(dart), "--out", str(out)]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert "'tolerance' must be a positive number of parameter units" in line, line
    assert not out.exists()


def test_a_file_name_too_long_for_the_system_is_one_line(tmp_path, capsys):
    for name in (f"{LONG_NAME}.json", LONG_NAME):
        assert main(["info", str(tmp_path / name)]) == 2
        (line,) = capsys.readouterr().err.splitlines()
        assert line.startswith("flatweave: error: ") and len(line) <= 500, line


def test_planes_of_huge_coefficients_are_the_plane_they_mean():
    """1e308 x - 1e308 y = 0 is the plane x = y: the dart's sides and the yarn's signed distance
    are those of 1 x - 1 y = 0, with no overflow."""
    xyz = np.array([[0.3, 0.1, 0.5], [0.1, 0.3, 0.5], [0.2, 0.2, 0.9]])
    huge, plain = PlaneDart((1e308, -1e308, 0.0, 0.0)), PlaneDart((1.0, -1.0, 0.0, 0.0))
    assert (np.sign(huge.F(xyz)) == np.sign(plain.F(xyz))).all()
    y = YarnConstraint("weft", 0, (1e308, -1e308, 0.0, 0.0), 1000.0).unit_plane()
    np.testing.assert_allclose(y, np.array([1.0, -1.0, 0.0, 0.0]) / np.sqrt(2.0))
    s = load_example("octant")
    assert len(huge.curve_uv(s)) == len(plain.curve_uv(s))
    with pytest.raises(SettingsError):
        PlaneDart((np.inf, 0.0, 0.0, 0.0))


def _net(n: int, bump: float):
    """An n x n cubic net over the unit square, z = bump sin(6u) cos(5v) at its control points."""
    from flatweave.geometry.meshfit import clamped_knots
    from flatweave.geometry.nurbs import NurbsSurface

    u = np.linspace(0.0, 1.0, n)
    U, V = np.meshgrid(u, u, indexing="ij")
    P = np.stack([U, V, bump * np.sin(6 * U) * np.cos(5 * V)], -1)
    return NurbsSurface(3, 3, clamped_knots(n), clamped_knots(n), P)


def test_a_fine_nets_area_takes_a_bounded_number_of_nodes_and_keeps_its_precision(monkeypatch):
    """Issue 45, item 5: a 400 x 400 net's area took 16 x 16 nodes a cell, 40 million at once (killed
    for memory): a fine net's cells take fewer (at least 4 x 4), evaluated in chunks."""
    from flatweave.geometry import quadrature as q

    flat = _net(400, 0.0)
    seen = []
    rule = q.domain_gauss_rule
    monkeypatch.setattr(q, "domain_gauss_rule", lambda s, n: seen.append(n) or rule(s, n))
    assert q.region_area(flat) == pytest.approx(1.0, rel=1e-12)  # every chunk summed, once
    assert seen == [q.AREA_MIN_N]
    curved = _net(100, 0.1)  # 97 x 97 cells: 10 nodes a cell here, 16 by the plain rule
    fewer = q.region_area(curved)
    monkeypatch.setattr(q, "AREA_NODES", 10**12)
    assert fewer == pytest.approx(q.region_area(curved), rel=1e-11) and seen[-2:] == [10, 16]
