"""Regions drawn on the surface (flatweave.geometry.region.region_from_spec) and offsets along it.

Oracles from outside the code: the half cylinder (radius 1/2 round the y axis)
and the half cone (slope sqrt 3, so any piece of it seen from above has twice
its plan area) are developable, so a region drawn on them from above has an
area and a boundary length computed from the plan drawing alone (closed form
or scipy quad of the analytic surface), and flattens to its own shape. The
offset region of a rectangle of the unrolled cylinder is the plane's offset
rectangle (rounded corners outwards, sharp inwards); on the unit sphere a
geodesic offset lies a great-circle distance |d| from the loop.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad

from flatweave.errors import SettingsError
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import flatten
from flatweave.reading.registry import open_path
from flatweave.geometry.region import (Region, RegionDrawing, check_region_size, cover_for, offset_region,
                         region_from_spec)

ROOT = Path(__file__).resolve().parent.parent
DOWN = [0.0, 0.0, -1.0]
R_CYL = 0.5


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "flatweave", *map(str, args)], capture_output=True, text=True,
                          cwd=ROOT, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"}, timeout=600)


@pytest.fixture(scope="module")
def cyl():
    return open_path("half_cylinder").surface


@pytest.fixture(scope="module")
def cone():
    return open_path("cone").surface


@pytest.fixture(scope="module")
def octant():
    return open_path("octant").surface


def _above(plan, z=2.0):
    return [[float(x), float(y), z] for x, y in plan]


def _cyl_width(x0, x1):  # arc length round the cylinder between plan abscissae x0 < x1
    return R_CYL * (math.asin(x1 / R_CYL) - math.asin(x0 / R_CYL))


def _cyl_exact(plan):
    """Area and boundary length on the half cylinder of the region over a plan polygon whose edges
    are each x = linear in y (quad of the analytic surface z = sqrt(R^2 - x^2))."""
    P = np.asarray(plan, float)
    area, length = 0.0, 0.0
    for a, b in zip(P, np.roll(P, -1, axis=0)):
        def speed(t, a=a, b=b):
            x = a[0] + t * (b[0] - a[0])
            dz = -x / math.sqrt(R_CYL ** 2 - x * x) * (b[0] - a[0])
            return math.sqrt((b[0] - a[0]) ** 2 + (b[1] - a[1]) ** 2 + dz * dz)
        length += quad(speed, 0, 1, epsabs=1e-14, epsrel=1e-13)[0]
        # Green: area = - integral of W(x) dy, W(x) = R asin(x / R) the unrolled abscissa
        area -= quad(lambda t, a=a, b=b: R_CYL * math.asin((a[0] + t * (b[0] - a[0])) / R_CYL) * (b[1] - a[1]),
                     0, 1, epsabs=1e-14, epsrel=1e-13)[0]
    return abs(area), length


def _cone_exact(plan):
    P = np.asarray(plan, float)
    x, y = P[:, 0], P[:, 1]
    area = 2.0 * 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    length = 0.0
    for a, b in zip(P, np.roll(P, -1, axis=0)):
        def speed(t, a=a, b=b):
            p = a + t * (b - a)
            dr = float(np.dot(p, b - a)) / math.hypot(*p)
            return math.sqrt(float(np.dot(b - a, b - a)) + 3.0 * dr * dr)  # z = sqrt(3) (1 - r)
        length += quad(speed, 0, 1, epsabs=1e-14, epsrel=1e-13)[0]
    return area, length


CYL_PLAN = [(-0.3, 0.3), (0.35, 0.25), (0.2, 1.1), (-0.4, 1.2)]
ANG = np.radians([20, 60, 100, 140])
CONE_PLAN = np.vstack([np.column_stack([0.95 * np.cos(ANG), 0.95 * np.sin(ANG)]),
                       np.column_stack([0.62 * np.cos(ANG[::-1]), 0.62 * np.sin(ANG[::-1])])])


@pytest.mark.parametrize("name", ["half_cylinder", "cone"])
def test_a_drawn_region_on_a_developable_flattens_to_itself(name, cyl, cone):
    # the pattern's outline error falls as spacing^2 (measured on the cylinder: 0.062 % at 0.05, 0.020 % at 0.03)
    surface, plan, exact, spacing = ((cyl, CYL_PLAN, _cyl_exact, 0.03) if name == "half_cylinder"
                                     else (cone, CONE_PLAN, _cone_exact, 0.05))
    region = region_from_spec(surface, {"points": _above(plan), "view_direction": DOWN})
    assert region.drawn == RegionDrawing("points", tuple(map(tuple, _above(plan))), (), (0.0, 0.0, -1.0))
    assert len(region.corners[0]) == len(plan)  # the drawn points are the loop's corners
    cover = cover_for(surface, region)
    area, length = exact(plan)
    assert cover.area == pytest.approx(area, rel=2e-5)
    assert cover.boundary_length == pytest.approx(length, rel=2e-5)
    r = flatten(surface, FlattenSettings(spacing=spacing, region=region, seed=cover.default_seed))
    m = r.metrics
    assert cover.contains(r.uv).all()
    assert abs(m["area_error_pct"]) < 0.05 and abs(m["boundary_error_pct"]) < 0.05, m
    assert m["max_thread_strain_pct"] < 0.05


def test_the_uv_form_is_fractions_of_the_domain(cone):
    uv = [[0.1, 0.2], [0.8, 0.1], [0.7, 0.9], [0.2, 0.8]]
    a = region_from_spec(cone, {"uv": uv, "holes": [[[0.4, 0.4], [0.5, 0.4], [0.45, 0.5]]]})
    b = region_from_spec(cone, {"outer": uv, "holes": [[[0.4, 0.4], [0.5, 0.4], [0.45, 0.5]]]})
    assert a.loops == b.loops and a.n_holes == 1 and a.drawn.form == "uv"  # the cone's domain is [0, 1]^2
    back = Region.from_dict(json.loads(json.dumps(a.to_dict())))
    assert back == a and back.drawn.to_dict() == {"uv": uv, "holes": [[[0.4, 0.4], [0.5, 0.4], [0.45, 0.5]]]}


@pytest.mark.slow
@pytest.mark.parametrize("d", [0.08, 0.03, -0.03, -0.1])
def test_an_offset_on_the_half_cylinder_is_the_unrolled_offset(cyl, d):
    x0, x1, y0, y1 = -0.3, 0.35, 0.3, 1.1  # a rectangle of the unrolled cylinder, seen from above
    spec = {"points": _above([(x0, y0), (x1, y0), (x1, y1), (x0, y1)]), "view_direction": DOWN}
    region = region_from_spec(cyl, spec, offset=d)
    w, h = _cyl_width(x0, x1), y1 - y0
    exact = w * h + 2 * (w + h) * d + (math.pi * d * d if d > 0 else 4 * d * d)  # round / sharp corners
    assert cover_for(cyl, region).area == pytest.approx(exact, rel=1e-3)
    assert abs(cover_for(cyl, region).area / exact - 1) < 1e-4  # measured: 7e-6 at most
    assert region.drawn.offset == d and region.drawn.to_dict()["offset"] == d
    # the drawing redraws the same region
    assert region_from_spec(cyl, region.drawn.to_dict()).loops == region.loops


def test_an_offset_on_the_sphere_is_a_geodesic_distance(octant):
    from flatweave.geometry.region import circle_loop
    base = Region.from_loops(circle_loop((0.5, 0.5), 0.2, 200, hole=False))
    for d in (0.1, -0.1):
        grown = offset_region(octant, base, d)
        p = octant.points(np.asarray(grown.loops[0]))
        q = octant.points(cover_for(octant, base).boundary_samples(0.001)[0][0])
        dist = np.arccos(np.clip(p @ q.T, -1, 1)).min(axis=1)  # great-circle distance to the loop
        assert np.allclose(dist, abs(d), rtol=2e-3), (dist.min(), dist.max())
        assert (cover_for(octant, grown).area > cover_for(octant, base).area) == (d > 0)


@pytest.mark.slow
def test_an_offset_clips_to_the_surface_and_refuses_to_vanish(cyl):
    whole_in = offset_region(cyl, None, -0.05)  # the whole domain's edge moved inwards
    w = math.pi * R_CYL
    assert cover_for(cyl, whole_in).area == pytest.approx((w - 0.1) * 1.4, rel=1e-4)
    near = region_from_spec(cyl, {"uv": [[0.05, 0.05], [0.5, 0.05], [0.5, 0.5], [0.05, 0.5]]}, offset=0.3)
    assert np.min(near.arrays()[0]) == pytest.approx(0.0, abs=1e-12)  # clipped to the domain
    with pytest.raises(SettingsError, match="leaves nothing"):
        region_from_spec(cyl, {"uv": [[0.4, 0.4], [0.6, 0.4], [0.6, 0.6], [0.4, 0.6]]}, offset=-0.3)
    with pytest.raises(SettingsError, match="leaves nothing"):  # geodesics far past the domain's edge
        offset_region(cyl, None, -1.8)
    with pytest.raises(SettingsError, match=r"a distance from -1\.871 to 1\.871 \(the surface's size\)"):
        offset_region(cyl, None, -5.0)  # beyond the surface's size: refused before any geodesic is traced
    grown = offset_region(cyl, None, 1.8)  # clipped: the whole domain
    assert cover_for(cyl, grown).area == pytest.approx(w * 1.5, rel=1e-9)


@pytest.mark.parametrize("spec, message", [
    ({"uv": [[0.1, 0.1], [0.9, 0.9], [0.9, 0.4], [0.1, 0.9]]}, "outer loop crosses itself"),
    ({"points": _above([(-0.3, 0.3), (0.7, 0.3), (0.2, 1.0)]), "view_direction": DOWN},
     "point 2 of the region's outer loop misses the surface"),
    ({"uv": [[0.1, 0.1], [1.2, 0.1], [0.5, 0.9]]}, "point 2 of the region's outer loop lies outside"),
    ({"uv": [[0.1, 0.1], [0.5, 0.1], [0.5, 0.5]], "holes": [[[0.7, 0.7], [0.8, 0.7], [0.8, 0.8]]]},
     "hole 1 of the region lies outside the outer loop"),
    ({"uv": [[0.1, 0.1], [0.5, 0.1], [0.5, 0.5]], "holes": [[[0.4, 0.2], [0.8, 0.2], [0.8, 0.3]]]},
     "hole 1 of the region crosses or touches the outer loop"),
    ({"uv": [[0.1, 0.1], [0.9, 0.1], [0.9, 0.9]], "holes": [[[0.5, 0.2], [0.8, 0.2], [0.8, 0.5]],
                                                         [[0.7, 0.3], [0.85, 0.3], [0.85, 0.8]]]},
     "holes 1 and 2 of the region overlap"),
    ({"points": _above([(-0.3, 0.3), (0.3, 0.3)]), "view_direction": DOWN}, "needs at least 3 points"),
    ({"points": _above([(-0.3, 0.3), (0.3, 0.3), (0, 1)])}, "needs 'view_direction'"),
    ({"outer": [[0, 0], [1, 0], [1, 1]], "uv": [[0, 0], [1, 0], [1, 1]]}, "exactly one of"),
])
def test_bad_regions_are_one_line(cyl, spec, message):
    with pytest.raises(SettingsError, match=message) as exc:
        region_from_spec(cyl, spec)
    assert "\n" not in str(exc.value)


def test_a_loop_leaving_the_surface_between_its_points_is_refused(cone):
    # the chord from one end of the half annulus to the other crosses its empty middle
    spec = {"points": _above([(0.8, 0.1), (0.75, 0.3), (-0.75, 0.3), (-0.8, 0.1)]), "view_direction": DOWN}
    with pytest.raises(SettingsError, match="leaves the surface between its points"):
        region_from_spec(cone, spec)


def test_a_region_smaller_than_a_few_cells_is_refused(cyl):
    small = region_from_spec(cyl, {"uv": [[0.4, 0.4], [0.45, 0.4], [0.45, 0.45], [0.4, 0.45]]})
    check_region_size(cyl, small, 0.01)
    with pytest.raises(SettingsError, match="under 6 cells at spacing 0.05"):
        check_region_size(cyl, small, 0.05)


def _sphere_ring(centre, radius_deg, n):
    c = np.asarray(centre, float) / np.linalg.norm(centre)
    a = np.cross(c, [0.0, 0.0, 1.0])
    a /= np.linalg.norm(a)
    b = np.cross(c, a)
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    r = math.radians(radius_deg)
    return (math.cos(r) * c + math.sin(r) * (np.cos(t)[:, None] * a + np.sin(t)[:, None] * b)).tolist()


@pytest.fixture(scope="module")
def holed_octant(octant, tmp_path_factory):
    """A ply drawn on the octant seen along (-1, -1, -1) with a hole, through the CLI."""
    tmp = tmp_path_factory.mktemp("drawn")
    spec = {"points": _sphere_ring((1, 1, 1), 28, 9), "view_direction": [-1, -1, -1],
            "holes": [_sphere_ring((1.1, 1, 0.9), 8, 6)]}
    path = tmp / "ply.json"
    path.write_text(json.dumps(spec))
    out, dxf, svg = tmp / "r.json", tmp / "ply.dxf", tmp / "ply.svg"
    p = _cli("flatten", "octant", "--spacing", "0.04", "--region", path, "--region-offset", "0.02",
             "--out", out, "--export", dxf, "--export", svg, "--quiet")
    assert p.returncode == 0, p.stderr
    return spec, json.loads(out.read_text()), dxf, svg


@pytest.mark.slow
def test_a_drawn_hole_on_the_octant_is_in_the_pattern_and_exports(octant, holed_octant):
    spec, doc, dxf, svg = holed_octant
    rec = doc["region"]
    assert len(rec["loops_uv"]) == 2 and rec["drawn"]["offset"] == 0.02
    assert rec["drawn"]["points"] == spec["points"] and rec["drawn"]["holes"] == spec["holes"]
    for uv, xyz in zip(rec["loops_uv"], rec["loops_xyz"]):
        assert np.allclose(octant.points(np.asarray(uv)), xyz)
        assert np.allclose(np.linalg.norm(xyz, axis=1), 1.0)  # on the unit sphere
    region = Region.from_dict(doc["settings"]["region"])
    assert region.drawn.offset == 0.02 and region.n_holes == 1
    # the offset moved the hole inwards (it shrank) and the outer loop outwards
    cover = cover_for(octant, region)
    plain = cover_for(octant, region_from_spec(octant, spec))
    assert cover.loop_lengths[0] > plain.loop_lengths[0] and cover.loop_lengths[1] < plain.loop_lengths[1]
    assert doc["pattern"]["pieces"][0]["region_holes"] == 1
    import ezdxf
    layers = [e.dxf.layer for b in ezdxf.readfile(dxf).blocks for e in b]
    assert layers.count("11") == 1  # the hole's cut-out
    text = svg.read_text()
    group = text.split('id="layer-11-cutout"', 1)[1].split("</g>", 1)[0]
    assert group.count("<polygon") == 1  # the hole's cut-out


def test_the_project_keeps_the_drawn_form(cyl, tmp_path):
    from flatweave.document.project import load_project, new_project, save_project
    region = region_from_spec(cyl, {"points": _above(CYL_PLAN), "view_direction": DOWN}, offset=0.02)
    path = save_project(new_project(cyl, "ply", units="m", region=region), tmp_path / "ply.flatweave")
    back = load_project(path)
    assert back.settings.region == region and back.settings.region.drawn.offset == 0.02
    assert back.settings.region.drawn.to_dict()["view_direction"] == DOWN


@pytest.mark.slow
def test_the_cli_refuses_bad_regions_in_one_line(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"uv": [[0.1, 0.1], [0.9, 0.9], [0.9, 0.4], [0.1, 0.9]]}))
    out = tmp_path / "r.json"
    p = _cli("flatten", "half_cylinder", "--spacing", "0.05", "--region", bad, "--out", out)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "crosses itself" in p.stderr
    small = tmp_path / "small.json"
    small.write_text(json.dumps({"uv": [[0.4, 0.4], [0.45, 0.4], [0.45, 0.45], [0.4, 0.45]]}))
    p = _cli("flatten", "half_cylinder", "--spacing", "0.05", "--region", small, "--out", out)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "under 6 cells" in p.stderr
    ok = tmp_path / "ok.json"
    ok.write_text(json.dumps({"uv": [[0.1, 0.1], [0.6, 0.1], [0.6, 0.6], [0.1, 0.6]]}))
    p = _cli("flatten", "half_cylinder", "--spacing", "0.05", "--region", ok, "--seed", "0.8,0.8", "--out", out)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "outside the piece's region" in p.stderr
    assert not out.exists()
    p = _cli("flatten", "half_cylinder", "--spacing", "0.05", "--region", ok, "--out", out, "--quiet")
    assert p.returncode == 0, p.stderr
    d = json.loads(out.read_text())
    seed = cover_for(open_path("half_cylinder").surface, Region.from_dict(d["settings"]["region"])).default_seed
    assert d["settings"]["seed"] == pytest.approx(list(seed))  # the pole of inaccessibility
    assert d["region"]["drawn"] == {"uv": [[0.1, 0.1], [0.6, 0.1], [0.6, 0.6], [0.1, 0.6]]}


def test_with_offset_replaces_the_drawn_offset_and_keeps_an_inside_seed():
    """flatweave.geometry.region.with_offset (the settings panel's Region offset): the offset is the
    drawing's, not added to it; 0 gives the region as drawn; the seed stays while inside."""
    from flatweave.reading.examples import load_example
    from flatweave.geometry.region import with_offset

    s = load_example("octant")
    spec = {"uv": [[0.2, 0.2], [0.8, 0.2], [0.8, 0.8], [0.2, 0.8]]}
    drawn = region_from_spec(s, spec)
    grown, seed = with_offset(s, drawn, 0.05, 0.05, None, (0.5, 0.5))
    assert grown.drawn.offset == 0.05 and seed == (0.5, 0.5)
    again, _ = with_offset(s, grown, 0.05, 0.05)
    assert again.loops == grown.loops  # replaced, not 0.1
    np.testing.assert_allclose(cover_for(s, grown).area, cover_for(s, region_from_spec(s, spec, 0.05)).area,
                               rtol=1e-12)
    back, _ = with_offset(s, grown, 0.0, 0.05)
    assert back.loops == drawn.loops and back.drawn.offset == 0.0
    # a seed left outside by an inward offset moves to the region's own default seed
    shrunk, seed = with_offset(s, drawn, -0.1, 0.05, None, (0.21, 0.21))
    assert seed == cover_for(s, shrunk).default_seed
    with pytest.raises(SettingsError, match="only a drawn region"):
        with_offset(s, Region.from_loops([[0.1, 0.1], [0.9, 0.1], [0.5, 0.9]]), 0.05, 0.05)
    with pytest.raises(SettingsError, match="under 6 cells"):
        with_offset(s, drawn, -0.1, 0.5)
