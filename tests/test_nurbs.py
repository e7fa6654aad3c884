"""NurbsSurface against geomdl (the oracle), finite differences and exact geometry."""

from __future__ import annotations

import numpy as np
import pytest
from geomdl import NURBS, exchange

import flatweave.geometry.nurbs as nurbs
from flatweave.errors import SurfaceError
from flatweave.reading.examples import example_names, example_path, load_example
from flatweave.geometry.nurbs import NurbsSurface

ORACLE_TOL = 1e-10
DERIVS = ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2))


# ---------------------------------------------------------------------- helpers
def to_geomdl(s: NurbsSurface) -> NURBS.Surface:
    """geomdl twin of ``s``, with the knot vectors kept as they are (no rescaling)."""
    g = NURBS.Surface(normalize_kv=False)
    g.degree_u, g.degree_v = s.degree_u, s.degree_v
    g.ctrlpts_size_u, g.ctrlpts_size_v = s.shape
    g.ctrlpts = s.ctrlpts.reshape(-1, 3).tolist()
    g.weights = s.weights.ravel().tolist()
    g.knotvector_u = s.knots_u.tolist()
    g.knotvector_v = s.knots_v.tolist()
    return g


def geomdl_derivatives(g, uv: np.ndarray) -> dict[tuple[int, int], np.ndarray]:
    """{(a, b): (n, 3)} derivatives d^(a+b) S / du^a dv^b from geomdl, a + b <= 2."""
    skl = [g.derivatives(float(u), float(v), order=2) for u, v in uv]
    return {ab: np.array([d[ab[0]][ab[1]] for d in skl], dtype=float) for ab in DERIVS}


def ours(s: NurbsSurface, uv: np.ndarray) -> dict[tuple[int, int], np.ndarray]:
    ev = s.evaluate(uv, second=True)
    return {(0, 0): ev.xyz, (1, 0): ev.su, (0, 1): ev.sv,
            (2, 0): ev.suu, (1, 1): ev.suv, (0, 2): ev.svv}


def assert_matches_geomdl(s: NurbsSurface, g, uv: np.ndarray, tol: float = ORACLE_TOL) -> None:
    """Each quantity agrees with geomdl to ``tol`` relative to its largest magnitude (at least 1)."""
    mine, ref = ours(s, uv), geomdl_derivatives(g, uv)
    for ab in DERIVS:
        scale = max(1.0, float(np.abs(ref[ab]).max()))
        err = float(np.abs(mine[ab] - ref[ab]).max())
        assert err <= tol * scale, f"derivative {ab}: max error {err:.3g} (scale {scale:.3g})"


def sample_params(s: NurbsSurface, rng: np.random.Generator, n: int = 24) -> np.ndarray:
    """(m, 2): random points, the domain's corners and edge midpoints, and points on every knot."""
    (u0, u1), (v0, v1) = s.domain
    rand = np.column_stack([rng.uniform(u0, u1, n), rng.uniform(v0, v1, n)])
    ends = np.array([[u0, v0], [u1, v0], [u1, v1], [u0, v1],
                     [u0, (v0 + v1) / 2], [u1, (v0 + v1) / 2], [(u0 + u1) / 2, v0], [(u0 + u1) / 2, v1]])
    nu, nv = s.shape
    ku = np.unique(s.knots_u[s.degree_u:nu + 1])
    kv = np.unique(s.knots_v[s.degree_v:nv + 1])
    on_knots = np.column_stack([ku, rng.uniform(v0, v1, ku.size)])
    on_knots_v = np.column_stack([rng.uniform(u0, u1, kv.size), kv])
    return np.concatenate([rand, ends, on_knots, on_knots_v])


def random_knots(rng: np.random.Generator, n: int, p: int, clamped: bool) -> np.ndarray:
    """(n + p + 1,) non-uniform knots, with a repeated interior knot now and then.

    Distinct knots are at least 0.02 of the range apart (well-conditioned spans).
    The domain's last span [k[n-1], k[n]] is kept non-empty: with a repeated
    knot at the end of the domain both geomdl and NurbsSurface evaluate the
    end on an empty span (see test_domain_end_on_a_repeated_knot).
    """
    m = n + p + 1
    while True:
        if clamped:
            inner = np.sort(rng.uniform(0.0, 1.0, n - p - 1))
            if inner.size and rng.random() < 0.6:  # repeat one interior knot up to p times
                i = rng.integers(inner.size)
                reps = int(rng.integers(1, p + 1))
                inner = np.sort(np.concatenate([inner, np.full(reps - 1, inner[i])]))[: n - p - 1]
            k = np.concatenate([np.zeros(p + 1), inner, np.ones(p + 1)])
        else:  # free (unclamped) ends, domain [k[p], k[n]]
            k = np.sort(rng.uniform(0.0, 1.0, m))
            if rng.random() < 0.5 and m > 2 * p + 2:
                i = int(rng.integers(p + 1, m - p - 1))
                reps = int(rng.integers(1, p + 1))
                k[i:i + reps] = k[i]
                k = np.sort(k)
        k = -1.3 + 2.7 * k  # not [0, 1]
        d = np.diff(np.unique(k))
        mult = np.unique(k[1:-1], return_counts=True)[1]
        if (d.size == 0 or d.min() > 0.02 * (k[-1] - k[0])) and (mult.size == 0 or mult.max() <= p) \
                and k[p] < k[n] and k[n - 1] < k[n]:
            return k


def random_surface(seed: int) -> NurbsSurface:
    rng = np.random.default_rng(seed)
    p, q = (int(x) for x in rng.integers(1, 5, 2))
    nu, nv = p + 1 + int(rng.integers(0, 5)), q + 1 + int(rng.integers(0, 5))
    ku = random_knots(rng, nu, p, clamped=bool(seed % 2))
    kv = random_knots(rng, nv, q, clamped=bool(seed % 3))
    P = rng.normal(size=(nu, nv, 3))
    W = rng.uniform(0.2, 4.0, (nu, nv))
    return NurbsSurface(p, q, ku, kv, P, W)


# ---------------------------------------------------------------------- geomdl as oracle
@pytest.mark.parametrize("name", example_names())
def test_example_matches_geomdl(name):
    s = load_example(name)
    g = exchange.import_json(str(example_path(name)))[0]  # geomdl reads the file itself
    assert g.knotvector_u == s.knots_u.tolist() and g.knotvector_v == s.knots_v.tolist()
    rng = np.random.default_rng(7)
    (u0, u1), (v0, v1) = s.domain
    grid = np.stack(np.meshgrid(np.linspace(u0, u1, 7), np.linspace(v0, v1, 7), indexing="ij"), -1)
    uv = np.concatenate([grid.reshape(-1, 2), sample_params(s, rng)])
    assert_matches_geomdl(s, g, uv)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(40))
def test_random_rational_surface_matches_geomdl(seed):
    s = random_surface(seed)
    assert_matches_geomdl(s, to_geomdl(s), sample_params(s, np.random.default_rng(seed + 1000)))


@pytest.mark.parametrize("seed", range(10))
def test_normals_from_derivatives_are_those_of_evaluate(seed):
    s = random_surface(seed)
    uv = sample_params(s, np.random.default_rng(seed + 2000))
    ev = s.evaluate(uv)
    _, su, sv = s.derivatives(uv)
    np.testing.assert_array_equal(s.normals(uv, su, sv), ev.normal)


def test_random_surfaces_cover_the_cases():
    """The random family really has every degree, free ends, clamped ends and repeated knots."""
    surfaces = [random_surface(seed) for seed in range(40)]
    degrees = {d for s in surfaces for d in (s.degree_u, s.degree_v)}
    assert degrees == {1, 2, 3, 4}
    clamped = [s.knots_u[0] == s.knots_u[s.degree_u] for s in surfaces]
    assert any(clamped) and not all(clamped)

    def repeated_inside(k, p, n):
        inner = k[p + 1:n]
        return inner.size > 1 and np.any(np.diff(inner) == 0)

    assert any(repeated_inside(s.knots_u, s.degree_u, s.shape[0])
               or repeated_inside(s.knots_v, s.degree_v, s.shape[1]) for s in surfaces)
    assert all(s.rational for s in surfaces)


# ---------------------------------------------------------------------- finite differences
def interior_params(s: NurbsSurface, rng: np.random.Generator, per_cell: int = 2) -> np.ndarray:
    """(m, 2) points well inside knot-span cells (away from knots, where derivatives jump)."""
    nu, nv = s.shape
    bu = np.unique(s.knots_u[s.degree_u:nu + 1])
    bv = np.unique(s.knots_v[s.degree_v:nv + 1])
    pts = []
    for ua, ub in zip(bu[:-1], bu[1:]):
        for va, vb in zip(bv[:-1], bv[1:]):
            t = rng.uniform(0.2, 0.8, (per_cell, 2))
            pts.append(np.column_stack([ua + t[:, 0] * (ub - ua), va + t[:, 1] * (vb - va)]))
    return np.concatenate(pts)


@pytest.mark.parametrize("seed", range(12))
def test_derivatives_match_central_differences(seed):
    s = random_surface(seed)
    uv = interior_params(s, np.random.default_rng(seed))
    ev = s.evaluate(uv, second=True)
    width = s.domain[:, 1] - s.domain[:, 0]
    hu, hv = 1e-5 * width
    du, dv = np.array([hu, 0.0]), np.array([0.0, hv])
    Pu = (s.points(uv + du) - s.points(uv - du)) / (2 * hu)
    Pv = (s.points(uv + dv) - s.points(uv - dv)) / (2 * hv)
    eu_p, eu_m = s.evaluate(uv + du), s.evaluate(uv - du)
    ev_p, ev_m = s.evaluate(uv + dv), s.evaluate(uv - dv)
    checks = [
        (ev.su, Pu), (ev.sv, Pv),
        (ev.suu, (eu_p.su - eu_m.su) / (2 * hu)),
        (ev.svv, (ev_p.sv - ev_m.sv) / (2 * hv)),
        (ev.suv, (ev_p.su - ev_m.su) / (2 * hv)),
        (ev.suv, (eu_p.sv - eu_m.sv) / (2 * hu)),
    ]
    for k, (exact, fd) in enumerate(checks):
        scale = max(1.0, float(np.abs(exact).max()))
        assert np.abs(exact - fd).max() <= 1e-6 * scale, f"check {k}"


@pytest.mark.parametrize("seed", range(6))
def test_power_form_basis_matches_the_recurrence_inside_and_beyond_the_domain(seed):
    """The basis is evaluated from per-span polynomials built once by the
    Cox-de Boor recurrence; both must agree everywhere, including the
    polynomial extension beyond the domain that Newton iterates may visit and
    knot vectors with repeated knots and any scale."""
    from flatweave.geometry.nurbs import _Basis

    rng = np.random.default_rng(seed)
    for _ in range(40):
        p = int(rng.integers(1, 6))
        n = int(rng.integers(p + 1, p + 15))
        inner = np.sort(rng.random(n - p - 1))
        if len(inner) > 2:
            inner[1] = inner[0]  # a repeated knot
        scale = 10.0 ** rng.uniform(-3, 3)
        basis = _Basis(np.r_[np.zeros(p + 1), inner, np.ones(p + 1)] * scale, p, n)
        x = rng.uniform(-0.5, 1.5, 300) * scale
        spans = basis.spans(x)
        fast, slow = basis(spans, x, p + 1), basis._recurrence(spans, x, p + 1)
        for d in range(p + 2):
            assert np.abs(fast[d] - slow[d]).max() <= 1e-12 * max(np.abs(slow[d]).max(), 1e-300), (p, d)


# ---------------------------------------------------------------------- domain ends
@pytest.mark.parametrize("seed", range(8))
def test_domain_ends_are_limits_from_inside(seed):
    s = random_surface(seed)
    (u0, u1), (v0, v1) = s.domain
    v = np.linspace(v0, v1, 9)
    for u_end, inward in ((u0, 1.0), (u1, -1.0)):
        at = s.points(np.column_stack([np.full(9, u_end), v]))
        near = s.points(np.column_stack([np.full(9, u_end + inward * 1e-10 * (u1 - u0)), v]))
        assert np.abs(at - near).max() < 1e-7 * max(1.0, np.abs(at).max())
    u = np.linspace(u0, u1, 9)
    for v_end, inward in ((v0, 1.0), (v1, -1.0)):
        at = s.points(np.column_stack([u, np.full(9, v_end)]))
        near = s.points(np.column_stack([u, np.full(9, v_end + inward * 1e-10 * (v1 - v0))]))
        assert np.abs(at - near).max() < 1e-7 * max(1.0, np.abs(at).max())


def test_domain_end_on_a_repeated_knot():
    p, n = 2, 5
    ku = np.array([0.0, 0.1, 0.2, 0.45, 0.7, 0.7, 0.9, 1.0])  # domain [k[2], k[5]] = [0.2, 0.7]
    P = np.random.default_rng(3).normal(size=(n, 2, 3))
    s = NurbsSurface(p, 1, ku, [0, 0, 1, 1], P)
    end = s.points([[0.7, 0.5]])
    near = s.points([[0.7 - 1e-12, 0.5]])
    assert np.all(np.isfinite(end)) and np.abs(end - near).max() < 1e-9


@pytest.mark.parametrize("seed", [1, 7, 13, 19, 25])  # seed % 2 and seed % 3 non-zero: clamped u and v
def test_clamped_corners_are_control_points(seed):
    s = random_surface(seed)
    (u0, u1), (v0, v1) = s.domain
    corners = s.points([[u0, v0], [u1, v0], [u0, v1], [u1, v1]])
    P = s.ctrlpts
    expected = np.array([P[0, 0], P[-1, 0], P[0, -1], P[-1, -1]])
    np.testing.assert_allclose(corners, expected, atol=1e-13)


def test_evaluates_exactly_at_every_domain_end_like_geomdl():
    s = random_surface(5)
    (u0, u1), (v0, v1) = s.domain
    uv = np.array([[u, v] for u in (u0, u1) for v in (v0, v1)])
    assert_matches_geomdl(s, to_geomdl(s), uv)


# ---------------------------------------------------------------------- the octant's pole
def test_octant_pole_is_finite_with_the_radial_normal():
    s = load_example("octant")
    v = np.linspace(0.0, 1.0, 11)
    uv = np.column_stack([np.zeros_like(v), v])  # the control row u = 0 is the pole
    ev = s.evaluate(uv, second=True)
    for arr in (ev.xyz, ev.su, ev.sv, ev.normal, ev.suu, ev.suv, ev.svv):
        assert np.all(np.isfinite(arr))
    np.testing.assert_allclose(ev.xyz, np.tile([0.0, 0.0, 1.0], (11, 1)), atol=1e-15)
    assert np.abs(ev.sv).max() < 1e-14  # the pole: S_v vanishes
    assert np.linalg.norm(ev.su, axis=1).min() > 1.0  # S_u does not
    np.testing.assert_allclose(np.linalg.norm(ev.normal, axis=1), 1.0, atol=1e-15)
    np.testing.assert_allclose(ev.normal, np.tile([0.0, 0.0, 1.0], (11, 1)), atol=1e-8)
    # and geomdl agrees about points and derivatives there
    assert_matches_geomdl(s, exchange.import_json(str(example_path("octant")))[0], uv)


@pytest.mark.parametrize("u", [1e-15, 1e-12, 1e-10, 1e-6, 1e-4, 1e-2, 0.5, 1.0])
def test_octant_normals_are_radial_near_the_pole(u):
    s = load_example("octant")
    v = np.linspace(0.0, 1.0, 21)
    ev = s.evaluate(np.column_stack([np.full_like(v, u), v]))
    radial = ev.xyz / np.linalg.norm(ev.xyz, axis=1)[:, None]
    np.testing.assert_allclose(np.linalg.norm(ev.normal, axis=1), 1.0, atol=1e-15)
    assert np.abs(ev.normal - radial).max() < 1e-8


def test_octant_normals_radial_on_a_fine_sweep_towards_the_pole():
    s = load_example("octant")
    u = np.logspace(-16, -1, 301)
    U, V = np.meshgrid(u, np.linspace(0.0, 1.0, 21), indexing="ij")
    ev = s.evaluate(np.column_stack([U.ravel(), V.ravel()]))
    radial = ev.xyz / np.linalg.norm(ev.xyz, axis=1)[:, None]
    assert np.abs(ev.normal - radial).max() < 1e-8


# ---------------------------------------------------------------------- constructor validation
def _good():
    return dict(degree_u=1, degree_v=1, knots_u=[0, 0, 1, 1], knots_v=[0, 0, 1, 1],
                ctrlpts=[[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 1]]], weights=None)


BAD_CONSTRUCTOR = [
    (dict(degree_u=0), "degree_u"),
    (dict(degree_v=1.5), "degree_v"),
    (dict(degree_u=True), "degree_u"),
    (dict(degree_u=2), "too high"),
    (dict(knots_u=[0, 0, 1]), "knot"),
    (dict(knots_v=[0, 1, 0, 1]), "non-decreasing"),
    (dict(knots_u=[0, 0, np.nan, 1]), "nan"),
    (dict(knots_u=[1, 1, 1, 1]), "empty"),
    (dict(ctrlpts=[[[0, 0], [0, 1]], [[1, 0], [1, 1]]]), "shape"),
    (dict(ctrlpts=[[[0, 0, 0], [0, 1, np.inf]], [[1, 0, 0], [1, 1, 1]]]), "nan or infinity"),
    (dict(ctrlpts=[[[2, 2, 2]] * 2] * 2), "equal"),
    (dict(weights=[[1, 1], [1, 0]]), "positive"),
    (dict(weights=[[1, 1], [1, -2]]), "positive"),
    (dict(weights=[[1, 1], [1, np.nan]]), "nan"),
    (dict(weights=[1, 1, 1, 1]), "shape"),
    (dict(ctrlpts=[[["a", 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 1]]]), "not numbers"),
]


@pytest.mark.parametrize("change,keyword", BAD_CONSTRUCTOR, ids=[k for _, k in BAD_CONSTRUCTOR])
def test_constructor_rejects_bad_data(change, keyword):
    args = _good()
    args.update(change)
    with pytest.raises(SurfaceError) as info:
        NurbsSurface(**args)
    msg = str(info.value)
    assert keyword in msg.lower()
    assert "\n" not in msg


def test_constructor_rejects_too_high_multiplicity():
    with pytest.raises(SurfaceError, match="multiplicity"):
        NurbsSurface(1, 1, [0, 0, 0.5, 0.5, 0.5, 1, 1], [0, 0, 1, 1],
                     np.random.default_rng(0).normal(size=(5, 2, 3)))


def test_constructor_accepts_good_data_and_freezes_arrays():
    s = NurbsSurface(**_good())
    assert not s.rational and s.shape == (2, 2)
    with pytest.raises(ValueError):
        s.ctrlpts[0, 0, 0] = 5.0


@pytest.mark.parametrize("name", example_names())
def test_many_points_evaluated_in_blocks_give_the_same_numbers(name, monkeypatch):
    """Past EVAL_BLOCK points an evaluation goes block by block (its temporaries in the cache): bit for
    bit what one block gives, with and without second derivatives, a last block shorter than the rest."""
    s = load_example(name)
    d = s.domain
    rng = np.random.default_rng(7)
    uv = np.column_stack([rng.uniform(d[0, 0], d[0, 1], 2_500), rng.uniform(d[1, 0], d[1, 1], 2_500)])
    whole = s.evaluate(uv, second=True), s.evaluate(uv), s.derivatives(uv)
    monkeypatch.setattr(nurbs, "EVAL_BLOCK", 300)  # 9 blocks, the last of 100 points
    blocks = s.evaluate(uv, second=True), s.evaluate(uv), s.derivatives(uv)
    for key in ("xyz", "su", "sv", "normal", "suu", "suv", "svv"):
        assert np.array_equal(getattr(whole[0], key), getattr(blocks[0], key))
    assert blocks[1].suu is None and np.array_equal(whole[1].normal, blocks[1].normal)
    assert all(np.array_equal(a, b) for a, b in zip(whole[2], blocks[2]))
