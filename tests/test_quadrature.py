"""Area, boundary length and boundary sampling, against exact values; the bundled examples."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate, interpolate

from flatweave.errors import SettingsError
from flatweave.reading.examples import (example_info, example_names, example_path, list_examples, load_example,
                                        resources_dir)
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.geometry.quadrature import (boundary_length, boundary_polyline, composite_gauss, domain_gauss_rule,
                             edge_lengths, gauss_legendre_01, region_area)

REL = 1e-9
DOME_A = 0.6


def _dome_edge(a: float) -> float:
    c = math.sqrt(1 + a * a)
    return 4 / c * math.atan(a / c)


# closed forms, written out here independently of resources/make_surfaces.py
EXACT = {
    "cone": (math.pi * (0.5 + 1.0) * 1.0 / 2, math.pi * 0.5 + math.pi * 1.0 + 2 * 1.0),
    "octant": (math.pi / 2, 3 * math.pi / 2),
    "half_cylinder": (math.pi * 0.5 * 1.5, 2 * math.pi * 0.5 + 2 * 1.5),
    "saddle": (4 * math.sqrt(3) / 3 + 16 / 3 * math.asinh(1 / math.sqrt(2)) - 2 * math.pi / 9,
               4 * (math.sqrt(2) + math.asinh(1))),
    "dome": (DOME_A * 4 * _dome_edge(DOME_A), 4 * _dome_edge(DOME_A)),
}


def expected(name: str) -> tuple[float, float]:
    if name in EXACT:
        return EXACT[name]
    info = example_info(name)
    return info["reference_area"], info["reference_boundary_length"]


# ---------------------------------------------------------------------- the index
def test_index_lists_every_example_with_its_numbers():
    names = example_names()
    assert names == ["cone", "octant", "garment", "half_cylinder", "saddle", "dome"]
    for e in list_examples():
        assert (resources_dir() / "surfaces" / e["file"]).is_file()
        assert e["units"] == "m" and e["title"] and e["description"]
        assert e["recommended_spacing"] > 0
        assert "independent" in e["reference_method"]
        if e["name"] in EXACT:
            a, b = EXACT[e["name"]]
            assert e["exact_area"] == pytest.approx(a, rel=1e-14)
            assert e["exact_boundary_length"] == pytest.approx(b, rel=1e-14)
            assert e["reference_area"] == pytest.approx(a, rel=1e-10)
            assert e["reference_boundary_length"] == pytest.approx(b, rel=1e-10)
        else:
            assert e["exact_area"] is None and e["exact_boundary_length"] is None
            assert "no closed form" in e["reference_method"]


def test_example_lookup():
    assert example_path("octant") == resources_dir() / "surfaces" / "octant.json"
    assert resources_dir() == Path(__file__).resolve().parent.parent / "resources"
    with pytest.raises(SettingsError, match="unknown example"):
        example_path("teapot")
    a = list_examples()
    a[0]["name"] = "changed"
    assert list_examples()[0]["name"] == "cone"


# ---------------------------------------------------------------------- area and length
@pytest.mark.parametrize("name", example_names())
def test_area_and_boundary_of_every_example(name):
    s = load_example(name)
    area, length = expected(name)
    assert region_area(s) == pytest.approx(area, rel=REL)
    assert boundary_length(s) == pytest.approx(length, rel=REL)


def test_garment_reference_independently():
    """The index's garment numbers, recomputed with scipy's B-spline evaluator and a finer rule."""
    s = load_example("garment")
    spl = interpolate.NdBSpline((s.knots_u, s.knots_v), s.ctrlpts, (3, 3))
    bu, bv = np.unique(s.knots_u), np.unique(s.knots_v)
    x, w = np.polynomial.legendre.leggauss(30)
    x, w = (x + 1) / 2, w / 2

    def rule(b):
        h = np.diff(b)[:, None]
        return (b[:-1, None] + h * x).ravel(), (h * w).ravel()

    (tu, wu), (tv, wv) = rule(bu), rule(bv)
    U, V = np.meshgrid(tu, tv, indexing="ij")
    uv = np.column_stack([U.ravel(), V.ravel()])
    su, sv = spl(uv, nu=(1, 0)), spl(uv, nu=(0, 1))
    area = np.sum(np.outer(wu, wv).ravel() * np.linalg.norm(np.cross(su, sv), axis=1))
    length = 0.0
    for c in (0.0, 1.0):
        length += np.sum(wu * np.linalg.norm(spl(np.column_stack([tu, np.full_like(tu, c)]), nu=(1, 0)), axis=1))
        length += np.sum(wv * np.linalg.norm(spl(np.column_stack([np.full_like(tv, c), tv]), nu=(0, 1)), axis=1))
    info = example_info("garment")
    assert area == pytest.approx(info["reference_area"], rel=1e-11)
    assert length == pytest.approx(info["reference_boundary_length"], rel=1e-11)


def test_closed_forms_against_the_analytic_parametrisations():
    """Saddle and dome values by scipy quadrature of their analytic parametrisations."""
    opts = dict(epsabs=1e-14, epsrel=1e-13)
    saddle = integrate.dblquad(lambda y, x: math.sqrt(1 + x * x + y * y), -1, 1, -1, 1, **opts)[0]
    assert saddle == pytest.approx(EXACT["saddle"][0], rel=1e-11)
    a = DOME_A
    dome = integrate.dblquad(lambda y, x: 4 / (1 + x * x + y * y) ** 2, -a, a, -a, a, **opts)[0]
    assert dome == pytest.approx(EXACT["dome"][0], rel=1e-11)
    # one dome edge x = a: |dS/dy| = 2 / (1 + a^2 + y^2) (the projection is conformal, factor 2/(1+r^2))
    edge = integrate.quad(lambda y: 2 / (1 + a * a + y * y), -a, a, **opts)[0]
    assert 4 * edge == pytest.approx(EXACT["dome"][1], rel=1e-12)


def test_edge_lengths():
    np.testing.assert_allclose(edge_lengths(load_example("octant")), [math.pi / 2] * 3 + [0.0], atol=1e-13)
    np.testing.assert_allclose(edge_lengths(load_example("cone")), [math.pi, 1.0, math.pi / 2, 1.0], rtol=1e-13)
    np.testing.assert_allclose(edge_lengths(load_example("half_cylinder")),
                               [math.pi / 2, 1.5, math.pi / 2, 1.5], rtol=1e-13)


def test_planar_and_polynomial_exactness():
    # a bilinear flat parallelogram: Gauss with one point per span is already exact
    P = np.array([[[0, 0, 0], [1, 2, 0]], [[3, 0, 0], [4, 2, 0]]], dtype=float)
    s = NurbsSurface(1, 1, [0, 0, 2, 2], [5, 5, 6, 6], P)
    assert region_area(s, n=1) == pytest.approx(6.0, rel=1e-15)
    assert boundary_length(s, n=1) == pytest.approx(6 + 2 * math.sqrt(5), rel=1e-15)


def test_area_converges_with_n():
    s = load_example("saddle")
    errs = [abs(region_area(s, n) - EXACT["saddle"][0]) for n in (2, 4, 8)]
    assert errs[0] > errs[1] > errs[2]


def test_gauss_rules():
    x, w = gauss_legendre_01(5)
    assert np.sum(w) == pytest.approx(1.0) and np.sum(w * x**9) == pytest.approx(0.1, rel=1e-14)
    t, wt = composite_gauss(np.array([0.0, 0.5, 2.0]), 3)
    assert t.shape == (6,) and np.sum(wt * t**2) == pytest.approx(8 / 3, rel=1e-14)
    uv, wuv = domain_gauss_rule(load_example("garment"), 4)
    assert uv.shape == (4 * 5 * 16, 2) and np.sum(wuv) == pytest.approx(1.0, rel=1e-14)
    for bad in (0, -1, 2.5, True):
        with pytest.raises(ValueError):
            gauss_legendre_01(bad)


# ---------------------------------------------------------------------- the examples are exact
def _grid(s: NurbsSurface, k: int = 13) -> np.ndarray:
    (u0, u1), (v0, v1) = s.domain
    U, V = np.meshgrid(np.linspace(u0, u1, k), np.linspace(v0, v1, k), indexing="ij")
    return np.column_stack([U.ravel(), V.ravel()])


@pytest.mark.parametrize("name", ["octant", "dome"])
def test_sphere_examples_lie_on_the_unit_sphere(name):
    s = load_example(name)
    ev = s.evaluate(_grid(s))
    np.testing.assert_allclose(np.linalg.norm(ev.xyz, axis=1), 1.0, atol=1e-14)
    np.testing.assert_allclose(ev.normal, ev.xyz, atol=1e-8)  # outward radial
    if name == "octant":
        assert np.all(ev.xyz >= -1e-15)


def test_dome_is_the_inverse_stereographic_square():
    s = load_example("dome")
    uv = _grid(s)
    x, y = (2 * uv[:, 0] - 1) * DOME_A, (2 * uv[:, 1] - 1) * DOME_A
    r2 = x * x + y * y
    expected_xyz = np.column_stack([2 * x, 2 * y, 1 - r2]) / (1 + r2)[:, None]
    np.testing.assert_allclose(s.points(uv), expected_xyz, atol=1e-14)
    assert np.all(s.weights > 0)
    maker = _load_maker()
    with pytest.raises(ValueError, match="weight"):
        maker.make_dome(0.75)


def test_cone_and_cylinder_shapes():
    cone = load_example("cone")
    ev = cone.evaluate(_grid(cone))
    rho = np.hypot(ev.xyz[:, 0], ev.xyz[:, 1])
    h = math.sqrt(3) / 2
    np.testing.assert_allclose(rho, 1.0 - 0.5 * ev.xyz[:, 2] / h, atol=1e-14)  # radius 1 -> 0.5 linearly
    assert ev.xyz[:, 1].min() >= -1e-15 and ev.xyz[:, 2].max() == pytest.approx(h)
    radial = np.column_stack([ev.xyz[:, :2] / rho[:, None], np.zeros(len(rho))])
    assert np.all(np.sum(ev.normal * radial, axis=1) > 0.8)  # outward
    cyl = load_example("half_cylinder")
    ev = cyl.evaluate(_grid(cyl))
    np.testing.assert_allclose(np.hypot(ev.xyz[:, 0], ev.xyz[:, 2]), 0.5, atol=1e-14)
    np.testing.assert_allclose(ev.normal[:, [0, 2]], ev.xyz[:, [0, 2]] / 0.5, atol=1e-8)
    assert ev.xyz[:, 1].min() == pytest.approx(0.0) and ev.xyz[:, 1].max() == pytest.approx(1.5)


def test_saddle_and_garment_shapes():
    s = load_example("saddle")
    xyz = s.points(_grid(s))
    np.testing.assert_allclose(xyz[:, 2], (xyz[:, 0] ** 2 - xyz[:, 1] ** 2) / 2, atol=1e-14)
    assert np.all(s.evaluate(_grid(s)).normal[:, 2] > 0)
    g = load_example("garment")
    ev = g.evaluate(_grid(g, 25))
    size = ev.xyz.max(axis=0) - ev.xyz.min(axis=0)
    assert 0.45 < size[0] < 0.55 and 0.55 < size[1] < 0.65 and 0.03 < size[2] < 0.15
    assert np.all(ev.normal[:, 2] > 0.5)  # faces forward, away from the body
    assert (g.degree_u, g.degree_v) == (3, 3) and g.shape == (7, 8) and not g.rational


def _load_maker():
    path = resources_dir() / "make_surfaces.py"
    spec = importlib.util.spec_from_file_location("make_surfaces", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_make_surfaces_reproduces_the_files():
    maker = _load_maker()
    from flatweave.geometry.surface_json import dumps_surface

    for name, make in maker.EXAMPLES.items():
        surface, _ = make()
        assert dumps_surface(surface) == example_path(name).read_text(encoding="utf-8")


# ---------------------------------------------------------------------- boundary_polyline
def _closed_chords(xyz: np.ndarray) -> np.ndarray:
    return np.linalg.norm(np.roll(xyz, -1, axis=0) - xyz, axis=1)


def _shoelace(uv: np.ndarray) -> float:
    x, y = uv[:, 0], uv[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def test_polyline_on_the_octant_skips_the_pole_edge():
    s = load_example("octant")
    uv, xyz = boundary_polyline(s, 10)
    assert uv.shape == (30, 2) and xyz.shape == (30, 3)
    np.testing.assert_allclose(xyz, s.points(uv), atol=0)
    np.testing.assert_allclose(xyz[0], [0, 0, 1], atol=1e-15)  # the pole, once
    assert np.sum(np.linalg.norm(xyz - [0, 0, 1], axis=1) < 1e-9) == 1
    chords = _closed_chords(xyz)  # every edge a quarter great circle cut in 10 equal arcs
    np.testing.assert_allclose(chords, 2 * math.sin(math.pi / 40), rtol=1e-12)
    assert _shoelace(uv) > 0
    # the edges in order: v = 0 with u increasing, u = 1, v = 1 with u decreasing
    assert np.all(uv[:10, 1] == 0) and np.all(np.diff(uv[:10, 0]) > 0)
    assert np.all(uv[10:20, 0] == 1) and np.all(np.diff(uv[10:20, 1]) > 0)
    assert np.all(uv[20:, 1] == 1) and np.all(np.diff(uv[20:, 0]) < 0)


def test_polyline_with_the_pole_on_the_first_edge():
    o = load_example("octant")  # transpose the net: the pole becomes the edge v = v0
    s = NurbsSurface(2, 2, o.knots_v, o.knots_u, o.ctrlpts.transpose(1, 0, 2), o.weights.T)
    uv, xyz = boundary_polyline(s, 7)
    assert uv.shape == (21, 2)
    np.testing.assert_allclose(xyz[0], [0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(uv[0], [1.0, 0.0])  # edge 0 skipped: edge 1 starts the walk
    assert np.min(np.linalg.norm(xyz[:, None] - xyz[None], axis=2) + 9 * np.eye(21)) > 0.1
    np.testing.assert_allclose(_closed_chords(xyz), 2 * math.sin(math.pi / 28), rtol=1e-12)


def test_polyline_is_even_in_arc_length_not_in_parameter():
    s = load_example("saddle")
    n = 16
    uv, xyz = boundary_polyline(s, n)
    assert uv.shape == (4 * n, 2)

    def arc(x):  # arc length of (x, c, (x^2 - c^2)/2) from x = -1, for |c| = 1
        return 0.5 * (x * np.sqrt(1 + x * x) + np.arcsinh(x)) - 0.5 * (-math.sqrt(2) - math.asinh(1))

    edge = math.sqrt(2) + math.asinh(1)
    x = xyz[:n, 0]  # edge 0: y = -1, x increasing
    np.testing.assert_allclose(arc(x), edge * np.arange(n) / n, atol=1e-13)
    assert np.ptp(np.diff(uv[:n, 0])) > 1e-3  # the parameter steps are not even
    y = xyz[n:2 * n, 1]  # edge 1: x = 1, y increasing
    np.testing.assert_allclose(arc(y), edge * np.arange(n) / n, atol=1e-13)


def test_polyline_cone_edges_and_counts_per_edge():
    s = load_example("cone")
    counts = (6, 3, 4, 5)
    uv, xyz = boundary_polyline(s, counts)
    assert uv.shape == (18, 2)
    lengths = [math.pi, 1.0, math.pi / 2, 1.0]
    start = 0
    for n, L, r in zip(counts, lengths, (1.0, None, 0.5, None)):
        pts = np.vstack([xyz[start:start + n], xyz[(start + n) % 18]])
        chords = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        want = L / n if r is None else 2 * r * math.sin(L / n / (2 * r))
        np.testing.assert_allclose(chords, want, rtol=1e-12)
        start += n
    assert _shoelace(uv) > 0


def test_polyline_converges_to_the_boundary_length_and_stays_even():
    s = load_example("garment")
    L = boundary_length(s)
    errs = []
    for n in (8, 32, 128):
        _, xyz = boundary_polyline(s, n)
        errs.append(L - _closed_chords(xyz).sum())
    assert all(e > 0 for e in errs) and errs[1] < errs[0] / 10 and errs[2] < errs[1] / 10
    n = 400  # many points (the arc-length table is refined): arcs between samples stay equal
    uv, _ = boundary_polyline(s, n)
    u = np.append(uv[:n, 0], 1.0)  # edge 0: v = 0, u increasing
    x, w = gauss_legendre_01(16)
    t = u[:-1, None] + np.diff(u)[:, None] * x[None, :]
    speed = np.linalg.norm(s.evaluate(np.column_stack([t.ravel(), np.zeros(t.size)])).su, axis=1)
    arcs = np.diff(u) * (speed.reshape(t.shape) @ w)
    # (this check's own Gauss rule is exact enough only on intervals without a knot inside)
    smooth = ~np.any((s.knots_u[None, :] > u[:-1, None]) & (s.knots_u[None, :] < u[1:, None]), axis=1)
    assert np.sum(~smooth) <= 3  # the interior knots 0.3, 0.5, 0.7
    np.testing.assert_allclose(arcs[smooth], edge_lengths(s)[0] / n, rtol=1e-11)


def test_polyline_rejects_bad_counts():
    s = load_example("saddle")
    for bad in (0, -2, 2.5, (1, 2, 3)):
        with pytest.raises(ValueError):
            boundary_polyline(s, bad)
