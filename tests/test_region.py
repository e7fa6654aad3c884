"""The piece to cover: a surface and a region of its (u, v) domain (flatweave.geometry.region).

Trimmed pieces are draped, minimised and flattened inside their region only;
the pattern's outline follows the outer loop and each hole of the region is a
hole of the pattern piece (layer 11 of the DXF). Developable trimmed pieces
(a planar face with a curved outline and a hole, a piece of a cylinder, both
written by Open CASCADE) flatten to their own shape. The whole domain takes
today's path (the other test files check that its numbers did not change).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from flatweave.errors import SettingsError
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import flatten
from flatweave.method.result import result_to_dict
from flatweave.geometry.quadrature import boundary_length, region_area as domain_area
from flatweave.reading.registry import open_path
from flatweave.geometry.region import Cover, Region, circle_loop, cover_for
from flatweave.geometry.uvregion import region_area
from tests.helpers import HAVE_OCP, needs_ocp

ROOT = Path(__file__).resolve().parent.parent

SQUARE = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
HOLE_C, HOLE_R = (0.45, 0.5), 0.15


def _cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "flatweave", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd or ROOT, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"}, timeout=600)


@pytest.fixture(scope="module")
def octant():
    return open_path("octant")


@pytest.fixture(scope="module")
def holed(octant):
    return Region.from_loops(SQUARE, [circle_loop(HOLE_C, HOLE_R, 400)])


@pytest.fixture(scope="module")
def holed_result(octant, holed):
    cover = cover_for(octant.surface, holed)
    return flatten(octant.surface, FlattenSettings(spacing=octant.spacing, region=holed, seed=cover.default_seed))


# ====================================================================== the region
def test_region_orients_its_loops_and_round_trips():
    r = Region.from_loops(SQUARE[::-1], [circle_loop(HOLE_C, HOLE_R, 64, hole=False)])
    outer, hole = r.arrays()
    def area(p):
        return 0.5 * float(np.dot(p[:, 0], np.roll(p[:, 1], -1)) - np.dot(p[:, 1], np.roll(p[:, 0], -1)))
    assert area(outer) > 0 > area(hole)
    again = Region.from_dict(json.loads(json.dumps(r.to_dict())))
    assert again == r and hash(again) == hash(r)
    assert Region.from_dict({"outer": SQUARE, "holes": [circle_loop(HOLE_C, HOLE_R, 64).tolist()]}).n_holes == 1
    with pytest.raises(SettingsError):
        Region.from_loops([[0, 0], [1, 1]])
    with pytest.raises(SettingsError):
        Region.from_dict({"holes": []})


def test_the_whole_domain_is_todays_values(octant):
    s = octant.surface
    whole = Cover(s)
    assert not whole.trimmed
    assert whole.area == domain_area(s) and whole.boundary_length == boundary_length(s)
    assert whole.default_seed == (0.5, 0.5)
    from flatweave.geometry.quadrature import boundary_samples
    (uv, xyz), holes = whole.boundary_samples(0.04)
    ref = boundary_samples(s, 0.04)
    assert holes == [] and np.array_equal(uv, ref[0]) and np.array_equal(xyz, ref[1])
    uv = np.random.default_rng(0).uniform(-0.2, 1.2, (500, 2))
    assert np.array_equal(whole.contains(uv), s.in_domain(uv))


def test_a_trimmed_cover_measures_its_region(octant, holed):
    s = octant.surface
    c = cover_for(s, holed)
    assert c is cover_for(s, Region.from_dict(holed.to_dict()))  # one per (surface, region)
    hole_area = region_area(s, [circle_loop(HOLE_C, HOLE_R, 400)])
    assert c.area == pytest.approx(math.pi / 2 - hole_area, rel=1e-9)
    # the loops' lengths: the square is the domain's edge; a finer circle converges on the hole's
    assert c.loop_lengths[0] == pytest.approx(boundary_length(s), rel=1e-10)
    fine = cover_for(s, Region.from_loops(SQUARE, [circle_loop(HOLE_C, HOLE_R, 4000)]))
    assert c.loop_lengths[1] == pytest.approx(fine.loop_lengths[1], rel=1e-4)
    # samples: on the loops, corners kept, about 4 a spacing
    (uv, xyz), holes = c.boundary_samples(0.04)
    for corner in SQUARE:
        assert np.min(np.linalg.norm(uv - corner, axis=1)) < 1e-12
    assert len(holes) == 1
    huv = holes[0][0]
    assert np.allclose(np.linalg.norm(huv - HOLE_C, axis=1), HOLE_R, rtol=2e-4)
    step = np.linalg.norm(np.diff(holes[0][1], axis=0), axis=1)
    assert step.max() < 1.05 * c.loop_lengths[1] / len(huv) and step.min() > 0.95 * c.loop_lengths[1] / len(huv)
    # inside: the hole is out, its edge counts as in
    pts = np.array([HOLE_C, [0.05, 0.05], [HOLE_C[0] + HOLE_R * 0.5, HOLE_C[1]], [1.5, 0.5], [np.nan, 0.2]])
    assert c.contains(pts).tolist() == [False, True, False, False, False]
    seed = c.seed_uv(c.default_seed)
    assert c.contains(seed[None])[0]
    assert np.linalg.norm(seed - HOLE_C) > HOLE_R + 0.1  # well away from the hole


def test_a_region_outside_the_domain_is_refused(octant):
    with pytest.raises(SettingsError, match="leaves the surface's domain"):
        Cover(octant.surface, Region.from_loops([[0, 0], [2, 0], [2, 1]]))


# ====================================================================== the octant with a hole
@pytest.mark.slow
def test_the_octant_with_a_hole(octant, holed, holed_result, tmp_path):
    r, s = holed_result, octant.surface
    cover = cover_for(s, holed)
    m = r.metrics
    hole_area = region_area(s, [circle_loop(HOLE_C, HOLE_R, 400)])
    assert m["area_3d"] == pytest.approx(math.pi / 2 - hole_area, rel=1e-6)
    assert m["boundary_length_3d"] == pytest.approx(boundary_length(s) + cover.loop_lengths[1], rel=1e-9)
    assert cover.contains(r.uv).all()  # every node in the region
    assert m["uncovered_pct"] < 0.5
    piece = r.pattern.pieces[0]
    assert piece.n_region_holes == 1 and len(r.pattern.holes) == 1
    hole2 = r.pattern.holes[0]
    perim = float(np.linalg.norm(np.roll(hole2, -1, axis=0) - hole2, axis=1).sum())
    assert perim == pytest.approx(cover.loop_lengths[1], rel=0.15)  # doubly curved: the hole stretches
    # the hole is inside the outline and counted in the area
    from shapely.geometry import Polygon
    assert Polygon(r.pattern.outline).contains(Polygon(hole2))
    assert m["area_2d"] == pytest.approx(r.pattern.area)
    assert abs(m["area_error_pct"]) < 5 and abs(m["boundary_error_pct"]) < 10
    d = result_to_dict(r, "octant")
    assert d["settings"]["region"]["loops"][1] and d["pattern"]["pieces"][0]["region_holes"] == 1
    # the DXF: the hole on layer 11 (internal cut-outs)
    from flatweave.export.registry import ExportOptions, export_all
    import ezdxf
    path = tmp_path / "octant.dxf"
    export_all(r, [path], ExportOptions(seam_allowance_mm=10, units="m"))
    doc = ezdxf.readfile(path)
    layers = [e.dxf.layer for b in doc.blocks for e in b]
    assert layers.count("11") == 1


def test_a_seed_outside_the_region_is_one_line(octant, holed):
    with pytest.raises(SettingsError, match="outside the piece's region"):
        flatten(octant.surface, FlattenSettings(spacing=0.04, region=holed, seed=(0.45, 0.5)))


def test_the_project_keeps_the_region(octant, holed, holed_result, tmp_path):
    from flatweave.document.project import PROJECT_VERSION, load_project, new_project, save_project, settings_equal
    p = new_project(octant.surface, "holed", units="m", region=holed).with_result(holed_result)
    assert p.settings.region == holed and p.settings.seed == cover_for(octant.surface, holed).default_seed
    path = save_project(p.with_settings(seed=holed_result.settings.seed, spacing=holed_result.settings.spacing),
                        tmp_path / "holed.flatweave")
    doc = json.loads(path.read_text())
    assert doc["version"] == PROJECT_VERSION >= 7 and doc["pieces"][0]["settings"]["region"]["loops"]
    back = load_project(path)
    assert back.settings.region == holed and back.result is not None
    assert settings_equal(back.settings, back.result.settings) and back.result_is_current
    assert back.result.pattern.pieces[0].n_region_holes == 1
    # an untrimmed project has a null region
    plain = json.loads(save_project(new_project(octant.surface, "plain"), tmp_path / "plain.flatweave").read_text())
    assert plain["pieces"][0]["settings"]["region"] is None


@pytest.mark.slow
def test_region_json_through_the_cli(tmp_path):
    region = tmp_path / "hole.json"
    region.write_text(json.dumps({"outer": SQUARE, "holes": [circle_loop(HOLE_C, HOLE_R, 200).tolist()]}))
    out = tmp_path / "r.json"
    p = _cli("flatten", "octant", "--spacing", "0.08", "--region", region, "--out", out, "--quiet")
    assert p.returncode == 0, p.stderr
    d = json.loads(out.read_text())
    assert d["settings"]["region"]["loops"] and d["pattern"]["pieces"][0]["region_holes"] == 1
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"outer": [[0, 0], [1, 1]]}))
    p = _cli("flatten", "octant", "--spacing", "0.08", "--region", bad, "--out", out)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "enclose an area" in p.stderr


# ====================================================================== CAD faces
@pytest.fixture(scope="module")
def cad_dir(tmp_path_factory):
    if not HAVE_OCP:
        pytest.skip("Open CASCADE is not installed (pip install cadquery-ocp-novtk)")
    from OCP.Geom import Geom_CylindricalSurface, Geom_Plane
    from OCP.gp import gp_Ax3, gp_Dir, gp_Pln, gp_Pnt

    from tests import cadfiles as cf
    d = tmp_path_factory.mktemp("cad")
    plane = Geom_Plane(gp_Pln(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)))
    outer = [cf.segment2d((5.0, 0.0), (35.0, 0.0)), cf.segment2d((35.0, 0.0), (35.0, 15.0)),
             (cf.circle2d(20.0, 15.0, 15.0), 0.0, math.pi), cf.segment2d((5.0, 15.0), (5.0, 0.0))]
    face = cf.trimmed_face(plane, outer, [[cf.circle2d(20.0, 12.0, 5.0, clockwise=True)]])
    cf.write_step(face, d / "plane.step")
    # a piece of a cylinder (radius 10; u in radians, v the height) with a hole round on the cylinder
    cyl = Geom_CylindricalSurface(gp_Ax3(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), 10.0)
    outer = [cf.segment2d((0.3, 0.0), (2.3, 0.0)), cf.segment2d((2.3, 0.0), (2.3, 15.0)),
             cf.segment2d((2.3, 15.0), (0.3, 15.0)), cf.segment2d((0.3, 15.0), (0.3, 0.0))]
    t = np.linspace(0, 2 * np.pi, 33)[:-1]
    hole = np.column_stack([1.3 + 0.4 * np.cos(-t), 7.5 + 4.0 * np.sin(-t)])
    cface = cf.trimmed_face(cyl, outer, [[cf.free_curve2d(hole)]])
    cf.write_step(cface, d / "cyl.step")
    cf.write_step(cf.compound(face, cface), d / "two.step")
    cf.write_iges(face, d / "plane.igs")
    return d


def _kabsch_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Largest distance between matched 2D points after the best rigid motion of a onto b."""
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    u, _, vt = np.linalg.svd((a - ca).T @ (b - cb))
    r = u @ vt
    if np.linalg.det(r) < 0:
        u[:, -1] *= -1
        r = u @ vt
    return float(np.linalg.norm((a - ca) @ r - (b - cb), axis=1).max())


@pytest.mark.slow
@needs_ocp
def test_a_planar_face_flattens_to_its_own_shape(cad_dir, tmp_path):
    opened = open_path(cad_dir / "plane.step")
    assert opened.face == 0 and opened.units == "mm" and opened.region is not None
    cover = cover_for(opened.surface, opened.region)
    exact_area = 30 * 15 + math.pi * 15 ** 2 / 2 - math.pi * 5 ** 2
    exact_length = 30 + 2 * 15 + math.pi * 15 + 2 * math.pi * 5
    assert cover.area == pytest.approx(exact_area, rel=1e-6)
    assert cover.boundary_length == pytest.approx(exact_length, rel=1e-6)
    out = tmp_path / "plane.json"
    p = _cli("flatten", cad_dir / "plane.step", "--spacing", "1", "--out", out, "--export", tmp_path / "plane.dxf",
             "--seam-allowance", "0", "--quiet")
    assert p.returncode == 0, p.stderr
    d = json.loads(out.read_text())
    m = d["metrics"]
    assert m["area_3d"] == pytest.approx(exact_area, rel=1e-6)
    assert m["boundary_length_3d"] == pytest.approx(exact_length, rel=1e-6)
    assert abs(m["area_error_pct"]) < 0.01 and abs(m["boundary_error_pct"]) < 0.01
    assert d["settings"]["face"] == 0 and d["settings"]["units"] == "mm"
    piece = d["pattern"]["pieces"][0]
    size = math.hypot(30, 30)
    outline, outline3d = np.array(piece["outline"]), np.array(piece["outline3d"])
    assert _kabsch_distance(outline, outline3d[:, :2]) < 1e-3 * size  # the outline is the face's edge
    assert piece["region_holes"] == 1
    hole = np.array(piece["holes"][0])
    # the hole's points sit on a circle of radius 5 whose centre is where the face's hole is
    centre3 = np.array([20.0, 12.0])
    ca, cb = outline.mean(axis=0), outline3d[:, :2].mean(axis=0)
    u, _, vt = np.linalg.svd((outline - ca).T @ (outline3d[:, :2] - cb))
    hole_on_face = (hole - ca) @ (u @ vt) + cb
    assert np.abs(np.linalg.norm(hole_on_face - centre3, axis=1) - 5.0).max() < 1e-3 * size
    import ezdxf
    doc = ezdxf.readfile(tmp_path / "plane.dxf")
    ents = [e for b in doc.blocks for e in b]
    assert [e.dxf.layer for e in ents].count("11") == 1
    cut = next(e for e in ents if e.dxf.layer == "1" and e.dxftype() == "POLYLINE")
    xs = np.array([(v.dxf.location.x, v.dxf.location.y) for v in cut.vertices])
    assert np.ptp(xs, axis=0).max() == pytest.approx(30.0, rel=2e-3)  # in the file's mm: no --units


@pytest.mark.slow
@needs_ocp
def test_a_trimmed_piece_of_a_cylinder_flattens_exactly(cad_dir, tmp_path):
    opened = open_path(cad_dir / "cyl.step")
    face = opened.cad.faces[0]
    assert face.kind == "cylinder" and face.trimmed
    r = flatten(opened.surface, FlattenSettings(spacing=0.5, region=opened.region,
                                                seed=cover_for(opened.surface, opened.region).default_seed))
    m = r.metrics
    assert m["area_3d"] == pytest.approx(face.area, rel=1e-6)  # against Open CASCADE's BRepGProp
    assert abs(m["area_error_pct"]) < 0.05 and abs(m["boundary_error_pct"]) < 0.05
    assert r.pattern.pieces[0].n_region_holes == 1
    assert cover_for(opened.surface, opened.region).contains(r.uv).all()


@pytest.mark.slow
@needs_ocp
def test_the_cli_lists_and_picks_faces(cad_dir, tmp_path):
    p = _cli("info", cad_dir / "two.step", "--json")
    assert p.returncode == 0, p.stderr
    info = json.loads(p.stdout)
    assert info["units"] == "mm" and [f["index"] for f in info["faces"]] == [0, 1]
    assert [f["kind"] for f in info["faces"]] == ["plane", "cylinder"]
    assert all(f["trimmed"] and len(f["bbox"]) == 6 and f["area"] > 0 for f in info["faces"])
    p = _cli("info", cad_dir / "two.step")
    assert p.returncode == 0 and "face 1: cylinder" in p.stdout and "trimmed" in p.stdout
    out = tmp_path / "r.json"
    p = _cli("flatten", cad_dir / "two.step", "--spacing", "1", "--out", out)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "--face" in p.stderr
    p = _cli("flatten", cad_dir / "two.step", "--spacing", "1", "--face", "2", "--out", out)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "out of range" in p.stderr
    p = _cli("flatten", cad_dir / "two.step", "--spacing", "100", "--face", "0", "--out", out)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "too small" in p.stderr
    p = _cli("flatten", cad_dir / "two.step", "--spacing", "1", "--face", "1", "--out", out, "--quiet")
    assert p.returncode == 0, p.stderr
    d = json.loads(out.read_text())
    assert d["settings"]["face"] == 1 and d["metrics"]["area_3d"] == pytest.approx(info["faces"][1]["area"], rel=1e-6)
    p = _cli("flatten", cad_dir / "plane.igs", "--spacing", "1", "--out", out, "--quiet")
    assert p.returncode == 0, p.stderr
    assert json.loads(out.read_text())["settings"]["units"] == "mm"


def test_a_version_3_project_opens_with_the_whole_domain():
    from flatweave.document.project import load_project, project_problems
    path = ROOT / "tests" / "data" / "projects" / "v3-octant-dart-solved.flatweave"
    raw = json.loads(path.read_text())
    assert raw["version"] == 3 and "region" not in raw["settings"]
    p = load_project(path)
    assert p.settings.region is None and p.result is not None and p.result_is_current
    assert p.result.mesh.n_nodes == 153 == raw["result"]["metrics"]["nodes"]
    np.testing.assert_allclose(p.result.pattern.xy, raw["result"]["nodes"]["xy"], atol=1e-9)
    assert p.result.metrics["area_3d"] == raw["result"]["metrics"]["area_3d"]
    assert project_problems(p) == []


def test_a_dart_opens_from_a_trimmed_edge(octant):
    from flatweave.method.darts import PlaneDart
    s = octant.surface
    disc = Region.from_loops(circle_loop((0.5, 0.5), 0.45, 400, hole=False))
    cover = cover_for(s, disc)
    dart = PlaneDart((1.0, -1.0, 0.0, 0.0), (0, 1, 0, 1, 0, 0.4), name="d")
    plain = flatten(s, FlattenSettings(spacing=0.04, region=disc, seed=cover.default_seed))
    r = flatten(s, FlattenSettings(spacing=0.04, region=disc, seed=cover.default_seed, darts=(dart,)))
    opening = r.pattern.darts[0]
    # the dart's curve is cut where it leaves the disc, and opens from there into a V
    assert opening.mouth and cover.edge_distance(opening.curve_uv[:1])[0] < 1e-9
    assert cover.contains(opening.curve_uv).all()
    assert opening.opening_deg > 5 and len(r.pattern.pieces) == 1 and r.pattern.holes == ()
    assert r.metrics["unmapped_points"] == 0
    assert abs(r.metrics["boundary_error_pct"]) < abs(plain.metrics["boundary_error_pct"])


def _rational_circle(centre, r):
    """A geomdl rational quadratic circle (counter-clockwise) as a trim curve."""
    s = math.sqrt(0.5)
    sq = [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1), (1, 0)]
    return {"type": "spline", "degree": 2,
            "knotvector": [0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1],
            "control_points": {"points": [[centre[0] + r * x, centre[1] + r * y] for x, y in sq],
                               "weights": [1, s, 1, s, 1, s, 1, s, 1]}}


@pytest.mark.slow
def test_a_geomdl_file_with_trims_is_a_trimmed_piece(octant, tmp_path):
    doc = json.loads(Path(octant.path).read_text())
    hole = dict(_rational_circle(HOLE_C, HOLE_R), reversed=1)  # clockwise: a hole
    doc["shape"]["data"][0]["trims"] = {"count": 1, "data": [hole]}
    path = tmp_path / "holed.json"
    path.write_text(json.dumps(doc))
    opened = open_path(path)
    assert opened.region is not None and opened.region.n_holes == 1
    loop = opened.region.arrays()[1]
    assert np.allclose(np.linalg.norm(loop - HOLE_C, axis=1), HOLE_R, rtol=1e-12)
    fine = region_area(octant.surface, [circle_loop(HOLE_C, HOLE_R, 20000)])
    assert cover_for(opened.surface, opened.region).area == pytest.approx(math.pi / 2 - fine, rel=1e-5)
    out = tmp_path / "r.json"
    p = _cli("flatten", path, "--spacing", "0.08", "--out", out, "--quiet")
    assert p.returncode == 0, p.stderr
    d = json.loads(out.read_text())
    assert d["metrics"]["area_3d"] == pytest.approx(math.pi / 2 - fine, rel=1e-5)
    assert d["pattern"]["pieces"][0]["region_holes"] == 1
    # a counter-clockwise trim bounds the piece; two of them are two pieces: refused in one line
    doc["shape"]["data"][0]["trims"] = {"count": 2, "data": [_rational_circle((0.3, 0.3), 0.2),
                                                             _rational_circle((0.7, 0.7), 0.2)]}
    path.write_text(json.dumps(doc))
    p = _cli("flatten", path, "--spacing", "0.08", "--out", out)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "outer" in p.stderr
    doc["shape"]["data"][0]["trims"] = {"count": 1, "data": [_rational_circle((0.5, 0.5), 0.4)]}
    path.write_text(json.dumps(doc))
    opened = open_path(path)
    assert opened.region.n_holes == 0
    assert cover_for(opened.surface, opened.region).contains(np.array([[0.5, 0.5], [0.05, 0.05]])).tolist() == \
        [True, False]


@pytest.mark.slow
@needs_ocp
@pytest.mark.parametrize("name", ["empty.step", "binary_garbage.step", "truncated.step", "garbage_body.step",
                                  "not_step.stp", "curve_only.igs", "not_iges.igs"])
def test_bad_cad_files_are_one_line_and_exit_2(tmp_path, name):
    """The bad-input corpus's CAD files: `info` and `flatten` each say what is wrong in one
    line and exit 2 (the reader runs Open CASCADE in a child process, so nothing it does
    can take the command down)."""
    path = ROOT / "tests" / "data" / "bad" / name
    for args in (("info", path), ("flatten", path, "--spacing", "1", "--out", tmp_path / "r.json")):
        p = _cli(*args)
        assert p.returncode == 2, (name, p.stderr)
        assert p.stderr.count("\n") == 1 and p.stderr.startswith("flatweave: error: "), (name, p.stderr)
        assert "Traceback" not in p.stderr
    assert not (tmp_path / "r.json").exists()
