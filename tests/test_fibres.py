"""Fibre angles and the lock metric: materials that carry their
shear angles, the isotropic lattice, ``area_beyond_lock_pct``, fibre angles
per cell (flatweave.method.fibres) and their CSV and VTP exports."""

import csv
import json
from dataclasses import replace

import numpy as np
import pytest

from flatweave.cli import main
from flatweave.errors import SettingsError
from flatweave.reading.examples import load_example
from flatweave.export.registry import ExportOptions, export, export_all
from flatweave.method.fibres import CSV_COLUMNS, cell_fibres, reference_direction, result_fibres
from flatweave.method.lattice import MATERIALS, Material, build_mesh
from flatweave.method.metrics import area_beyond_lock_pct, cell_areas, cell_shear_deg, metric_limits
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import flatten
from flatweave.method.result import judge_result
from flatweave.document.project import load_project, new_project, project_to_dict, save_project
from tests.helpers import diameter, hausdorff, rigid_align


def _rotation(seed=3):
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def sheared_sheet(alpha_deg, gamma_deg, n=5, r=0.1):
    """A flat lattice turned by alpha with every cell sheared by gamma (a
    parallelogram grid), then rotated into a general position: its weft makes
    alpha with the x axis and its warp 90 - gamma with the weft, exactly."""
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    ij = np.column_stack([i.ravel(), j.ravel()])
    a, g = np.radians(alpha_deg), np.radians(gamma_deg)
    weft = np.array([np.cos(a), np.sin(a), 0.0])
    warp = np.array([np.cos(a + np.pi / 2 - g), np.sin(a + np.pi / 2 - g), 0.0])
    xyz = r * (ij[:, 1:2] * weft + ij[:, 0:1] * warp)
    R = _rotation()
    mesh = build_mesh(ij, r, r, MATERIALS["woven"])
    return mesh, xyz @ R.T, ij.astype(float), R


# ---------------------------------------------------------------- fibre angles
@pytest.mark.parametrize("alpha, gamma", [(0.0, 0.0), (25.0, 12.0), (-40.0, -20.0), (70.0, 35.0)])
def test_a_sheared_sheet_has_its_known_angles(alpha, gamma):
    mesh, xyz, uv, R = sheared_sheet(alpha, gamma)
    # the rosette leans out of the plane: its projection is the x axis
    f = cell_fibres(xyz, uv, mesh, R @ np.array([1.0, 0.0, 0.7]))
    assert len(f.shear_deg) == len(mesh.cells) == 16
    np.testing.assert_allclose(f.deviation_deg, alpha, atol=1e-9)
    np.testing.assert_allclose(f.warp_deviation_deg, alpha - gamma, atol=1e-9)
    np.testing.assert_allclose(f.shear_deg, gamma, atol=1e-9)
    np.testing.assert_allclose(f.shear_deg, cell_shear_deg(xyz, mesh), atol=1e-12)
    np.testing.assert_allclose(f.deviation_deg - f.warp_deviation_deg, f.shear_deg, atol=1e-9)
    np.testing.assert_allclose(np.abs(f.normal @ (R @ [0, 0, 1.0])), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(f.weft, axis=1), 1.0)
    np.testing.assert_allclose(f.weft @ (R @ [1.0, 0, 0]), np.cos(np.radians(alpha)), atol=1e-12)


def test_a_rosette_normal_to_a_cell_gives_nan_not_a_number_from_noise():
    mesh, xyz, uv, R = sheared_sheet(10.0, 5.0)
    f = cell_fibres(xyz, uv, mesh, R @ np.array([0.0, 0.0, 1.0]))
    assert np.isnan(f.deviation_deg).all() and np.isfinite(f.shear_deg).all()


@pytest.mark.parametrize("angle", [0.0, 90.0])
def test_half_cylinder_along_its_rulings_deviates_nowhere(angle):
    """Developable, draped along its circle or rulings: the cloth does not shear and
    the projected rosette is the thread direction in every cell."""
    r = flatten(load_example("half_cylinder"), FlattenSettings(0.1, angle_deg=angle))
    f = result_fibres(r)
    assert len(f.shear_deg) > 50 and np.isfinite(f.deviation_deg).all()
    # the solve stops at the bent springs' precision (EN floor sum k r^2 (f - 1)^4 / 2, decision 0057),
    # which leaves an edge cell off by up to 1.6e-6 deg
    assert np.abs(f.deviation_deg).max() < 1e-5
    assert np.abs(f.warp_deviation_deg).max() < 1e-5
    assert np.abs(f.shear_deg).max() < 1e-5
    assert r.metrics["area_beyond_lock_pct"] == 0.0


def test_the_rosette_is_the_drapes_weft_at_the_seed():
    s = load_example("octant")
    r = flatten(s, FlattenSettings(0.1, angle_deg=30.0, solver="none"))
    np.testing.assert_allclose(reference_direction(s, r.settings), r.drape_stats["weft_direction"], atol=1e-12)
    # the four cells round the seed node start along the rosette: the drape lays the weft there
    f = result_fibres(r)
    seed = int(np.flatnonzero((r.mesh.ij == 0).all(axis=1))[0])
    near = np.flatnonzero((r.mesh.cells == seed).any(axis=1))
    assert len(near) == 4 and np.abs(f.deviation_deg[near]).max() < 5.0


# ---------------------------------------------------------------- exports
@pytest.fixture(scope="module")
def saddle():
    return flatten(load_example("saddle"), FlattenSettings(0.1, angle_deg=30.0))


def read_csv(path):
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return rows[0], np.array(rows[1:], dtype=float)


def test_fibre_csv_agrees_with_the_vtp(tmp_path, saddle):
    import pyvista as pv

    r = saddle
    paths = export_all(r, [tmp_path / "p.csv", tmp_path / "p.vtp"], ExportOptions())
    head, table = read_csv(paths[0])
    assert tuple(head) == CSV_COLUMNS
    col = {k: table[:, n] for n, k in enumerate(head)}
    vtp = pv.read(paths[1])
    c = vtp.n_cells
    assert len(table) == c == len(r.mesh.cells)
    np.testing.assert_array_equal(col["cell"], np.arange(c))
    quads = vtp.faces.reshape(-1, 5)[:, 1:]
    np.testing.assert_allclose(np.column_stack([col["x"], col["y"], col["z"]]), vtp.points[quads].mean(axis=1),
                               atol=1e-12)
    np.testing.assert_allclose(np.column_stack([col["u"], col["v"]]), vtp.point_data["uv"][quads].mean(axis=1),
                               atol=1e-12)
    for name, key in (("weft", "weft_dir"), ("warp", "warp_dir")):
        np.testing.assert_allclose(np.column_stack([col[f"{name}_{a}"] for a in "xyz"]), vtp.cell_data[key],
                                   atol=1e-12)
    np.testing.assert_allclose(col["deviation_deg"], vtp.cell_data["fibre_deviation_deg"], atol=1e-12)
    np.testing.assert_allclose(col["warp_deviation_deg"], vtp.cell_data["warp_deviation_deg"], atol=1e-12)
    np.testing.assert_allclose(col["shear_deg"], vtp.cell_data["shear_deg"], atol=1e-12)
    # the weft direction is the cell's weft springs': corner 0 to 1 and 3 to 2
    p = vtp.points[quads]
    w = (p[:, 1] - p[:, 0]) + (p[:, 2] - p[:, 3])
    np.testing.assert_allclose(vtp.cell_data["weft_dir"], w / np.linalg.norm(w, axis=1)[:, None], atol=1e-12)
    # a saddle at 30 degrees: the threads turn away from the rosette
    assert np.nanmax(np.abs(col["deviation_deg"])) > 5.0


def test_dxf_label_states_the_materials_angles(tmp_path):
    import ezdxf

    mat = replace(MATERIALS["woven"], warn_deg=12.0, lock_deg=25.0)
    r = flatten(load_example("saddle"), FlattenSettings(0.1, material=mat))
    path = export(r, tmp_path / "p.dxf", ExportOptions(name="saddle"))
    doc = ezdxf.readfile(path)
    texts = " ".join(e.dxf.text for b in doc.blocks for e in b if e.dxftype() == "TEXT")
    assert "shear warning 12 deg, lock 25 deg" in texts
    assert f"{r.metrics['area_beyond_lock_pct']:.1f} % of the area beyond lock" in texts


# ---------------------------------------------------------------- the lock metric
def test_area_beyond_lock_is_the_area_weighted_share(saddle):
    r = saddle
    shear, areas = cell_shear_deg(r.xyz, r.mesh), cell_areas(r.xyz, r.mesh)
    assert r.metrics["area_beyond_lock_pct"] == pytest.approx(area_beyond_lock_pct(shear, areas, 30.0))
    lock = float(np.percentile(np.abs(shear), 80))
    by_hand = 100 * sum(a for s, a in zip(np.abs(shear), areas) if s > lock) / areas.sum()
    assert area_beyond_lock_pct(shear, areas, lock) == pytest.approx(by_hand)
    assert 5 < by_hand < 40  # area-weighted, not a count of cells: near 20 % but not exactly
    # a material with that lock angle reports it in every result
    tight = flatten(load_example("saddle"), FlattenSettings(0.1, angle_deg=30.0,
                                                            material=replace(MATERIALS["woven"], warn_deg=lock / 2,
                                                                             lock_deg=lock)))
    assert tight.metrics["area_beyond_lock_pct"] == pytest.approx(by_hand, rel=1e-6)
    assert any("beyond the lock angle" in w for w in tight.warnings)
    assert metric_limits(tight.settings.material)["max_shear_deg"] == (lock / 2, lock)
    assert judge_result(tight).warnings == tight.warnings


def test_cli_reports_the_lock_share_and_takes_the_angles(tmp_path, capsys):
    out = tmp_path / "r.json"
    assert main(["flatten", "saddle", "--spacing", "0.1", "--angle", "30", "--shear-angles", "5,10",
                 "--out", str(out)]) == 0
    err = capsys.readouterr().err
    doc = json.loads(out.read_text())
    m = doc["metrics"]
    assert m["area_beyond_lock_pct"] > 0
    assert f"{m['area_beyond_lock_pct']:.3g} % of the area beyond the lock angle (10 deg)" in err
    assert doc["settings"]["material"]["lock_deg"] == 10.0 and doc["settings"]["material"]["warn_deg"] == 5.0
    for bad in ("5", "a,b", "20,10"):
        assert main(["flatten", "saddle", "--spacing", "0.1", "--shear-angles", bad, "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("flatweave: error:") and "angle" in err


# ---------------------------------------------------------------- materials
def test_the_isotropic_preset_is_isotropic():
    """C11 = k_a + k_d, C12 = C66 = k_d for the lattice with diagonals: isotropy
    needs C66 = (C11 - C12) / 2, k_d = k_a / 2 (Poisson's ratio C12 / C11 = 1/3)."""
    for name, isotropic in (("isotropic", True), ("paper-isotropic", False)):
        m = MATERIALS[name]
        assert m.k_weft == m.k_warp
        c11, c12 = m.k_weft + m.k_diag, m.k_diag
        assert (m.k_diag == (c11 - c12) / 2) is isotropic
    assert MATERIALS["paper-isotropic"].ratio == "100:100:100"
    assert MATERIALS["isotropic"].ratio == "100:100:50"


@pytest.mark.slow
def test_isotropic_pattern_depends_less_on_the_weft_angle_than_the_papers():
    """Example II: at 0 and 45 degrees the isotropic octant's outlines differ
    (Hausdorff after a rigid motion) less than with the paper's ratio."""
    s = load_example("octant")
    spread = {}
    for name in ("isotropic", "paper-isotropic"):
        a, b = (flatten(s, FlattenSettings(0.05, material=MATERIALS[name], angle_deg=ang)) for ang in (0.0, 45.0))
        A, B = rigid_align(a.pattern.outline, b.pattern.outline)
        spread[name] = 100 * hausdorff(A, B) / diameter(A)
    assert spread["isotropic"] < 0.5 * spread["paper-isotropic"], spread


def test_an_old_isotropic_project_opens_as_what_it_was(tmp_path):
    """Before project version 3 'isotropic' was 100:100:100, with no angles in the file."""
    s = load_example("octant")
    p = new_project(s, "octant")
    p = p.with_settings(material=MATERIALS["paper-isotropic"])
    d = project_to_dict(p)
    d["pieces"][0]["settings"]["material"] = {"name": "isotropic", "k_weft": 100.0, "k_warp": 100.0, "k_diag": 100.0}
    path = tmp_path / "old.flatweave"
    path.write_text(json.dumps(d))
    back = load_project(path)
    assert back.settings.material == MATERIALS["paper-isotropic"]
    # today's isotropic, and the angles, round-trip
    for mat in (MATERIALS["isotropic"], Material("custom 3:2:1", 3, 2, 1, 10.0, 40.0)):
        save_project(p.with_settings(material=mat), path)
        assert load_project(path).settings.material == mat


def test_bad_material_angles_are_refused():
    for w, lock in ((30.0, 15.0), (0.0, 10.0), (10.0, 95.0), (float("nan"), 30.0)):
        with pytest.raises(SettingsError, match="shear angles"):
            FlattenSettings(0.1, material=replace(MATERIALS["woven"], warn_deg=w, lock_deg=lock))


# ---------------------------------------------------------------- the window's map
@pytest.mark.slow
def test_the_windows_fibre_map_is_the_csvs_deviation(make_window, qtbot, tmp_path):
    from flatweave.app.colours import ramp
    from flatweave.app.viewbase import SCALE_TITLES, fibre_stops
    from tests.test_app_run import run_to_end, small_project

    from flatweave.app.panels import metric_colour

    tight = replace(MATERIALS["woven"], warn_deg=2.0, lock_deg=5.0)  # so that some cloth passes the lock
    win = make_window(small_project(0.1, angle_deg=30.0, material=tight))
    run_to_end(qtbot, win)
    r = win.project.result
    head, table = read_csv(export(r, tmp_path / "p.csv"))
    dev = table[:, list(head).index("deviation_deg")]
    assert np.nanmax(np.abs(dev)) > 1.0  # the octant's threads turn from the rosette
    win.actions["mode_fibre"].trigger()
    for view in (win.view, win.pattern_view):
        layer = view.layer
        assert layer.cell_actor.GetVisibility() and not any(a.GetVisibility() for a in layer.spring_actors)
        shown = np.asarray(layer.cells.cell_data["value"])
        np.testing.assert_allclose(shown, dev, atol=1e-9)
        # the colours on screen are the scale's: green along the rosette, red and blue its two sides
        stops = fibre_stops(layer.frame)
        np.testing.assert_allclose(layer.fibre_scale.map(shown), 255 * ramp(shown, stops), atol=1.01)
        assert stops[0][0] == pytest.approx(-np.nanmax(np.abs(dev)))
    assert [t for t, _ in win.view.colour_bars] == [SCALE_TITLES["fibre"]]
    cell = int(np.nanargmax(np.abs(dev)))
    assert f"fibre angle {dev[cell]:+.2f} deg" in win.view.layer.describe(win.view.layer.cell_actor, cell)
    # the metrics panel reports the result's lock share, against the material's lock angle
    pct = r.metrics["area_beyond_lock_pct"]
    assert pct > 0.5
    assert win.metrics.text("beyond_lock") == f"{pct:.2f} % of the area (lock 5 deg)"
    colour = metric_colour(pct, metric_limits(tight)["area_beyond_lock_pct"])
    assert colour in win.metrics.labels["beyond_lock"].styleSheet() and colour != "#207020"
    # back to shear: the same cells show |shear| again
    win.actions["mode_shear"].trigger()
    np.testing.assert_allclose(win.view.layer.cells.cell_data["value"], np.abs(table[:, -1]), atol=1e-9)
