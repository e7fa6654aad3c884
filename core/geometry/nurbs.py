"""NURBS surfaces: the data model and vectorised evaluation.

A :class:`NurbsSurface` holds degrees, knot vectors, an (nu, nv, 3) control net
and (nu, nv) weights. :meth:`NurbsSurface.evaluate` evaluates points, first (and
optionally second) partial derivatives and unit normals at an (n, 2) array of
(u, v) in one pass of numpy arithmetic: the B-spline basis of every parameter
is built by the Cox-de Boor recurrence over whole arrays, the control points of
each point's support are gathered, and the rational quotient rule is applied.
geomdl is the oracle for this module in the tests; it is never called here.

Parameters outside the domain are evaluated by polynomial extension of the end
spans (useful to Newton iterations that step briefly outside); callers decide
whether such points are acceptable.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flatweave.errors import SurfaceError

__all__ = ["NurbsSurface", "SurfaceEval", "basis_functions", "MIN_SIZE", "MAX_SIZE", "MAX_WEIGHT_RATIO"]

MIN_SIZE, MAX_SIZE = 1e-40, 1e40
"""Smallest and largest control net (bounding-box diagonal) accepted, in model
units: 20 orders of magnitude inside the scales where the squared lengths and
gradients underflow or overflow (docs/decisions/0007-refuse-unusable-surfaces-and-sizes.md)."""

MAX_WEIGHT_RATIO = 1e10
"""Largest ratio of the largest to the smallest weight accepted: a weight far
above its neighbours pulls a corner into a point whose normal is 0 / 0
(docs/decisions/0007-refuse-unusable-surfaces-and-sizes.md)."""


EVAL_BLOCK = 8_192
"""Points a surface evaluation takes at a time (:meth:`NurbsSurface.evaluate`): its temporaries stay in
the cache (640,000 points with second derivatives in 0.45 s instead of 0.66 to 0.93 s)."""


def _find_spans(knots: np.ndarray, degree: int, n_ctrl: int, x: np.ndarray) -> np.ndarray:
    """Knot span index k of every x, with knots[k] <= x < knots[k+1], clipped to [p, n-1]."""
    k = np.searchsorted(knots, x, side="right") - 1
    return np.minimum(np.maximum(k, degree), n_ctrl - 1)  # np.clip costs 15 us a call more


def _safe_inv(d: np.ndarray) -> np.ndarray:
    """1/d where d != 0, else 0 (the 0/0 := 0 convention of B-spline recurrences)."""
    out = np.zeros_like(d)
    nz = d != 0.0
    out[nz] = 1.0 / d[nz]
    return out


class _Basis:
    """B-spline basis of one knot vector, kept per span in power form.

    On span s every non-zero basis function is a polynomial of degree p in
    dx = x - t[s]: ``N_{s-p+r}(x) = sum_k C[s, r, k] dx^k``. The coefficients
    are the Taylor coefficients at t[s], found once by the Cox-de Boor
    recurrence (:meth:`_recurrence`); evaluation is then one gather and one
    contraction, whatever the degree, which is what the drape's small batches
    need (docs/decisions/0007-refuse-unusable-surfaces-and-sizes.md). Outside the domain the
    end spans' polynomials extend the surface, as the recurrence did.
    """

    def __init__(self, knots: np.ndarray, degree: int, n_ctrl: int):
        self.knots, self.p, self.n = knots, degree, n_ctrl
        s = np.arange(degree, n_ctrl)  # every valid span
        # non-empty span to use for each: the last non-empty one at or below it
        # (the first non-empty one for empty spans at the domain's start)
        nonempty = knots[s] < knots[s + 1]
        last = np.maximum.accumulate(np.where(nonempty, s, -1))
        first = s[np.argmax(nonempty)]
        self.span_map = np.where(last >= 0, last, first)
        self.left = {}   # (q, r) -> 1 / (t[i+q] - t[i]),     i = s - q + r, r >= 1
        self.right = {}  # (q, r) -> 1 / (t[i+q+1] - t[i+1]),             r <= q - 1
        for q in range(1, degree + 1):
            for r in range(q + 1):
                i = s - q + r
                if r >= 1:
                    self.left[q, r] = _safe_inv(knots[i + q] - knots[i])
                if r <= q - 1:
                    self.right[q, r] = _safe_inv(knots[i + q + 1] - knots[i + 1])
        taylor = self._recurrence(s, knots[s], degree)  # derivative k at t[s], (spans, p+1) each
        fact = np.cumprod(np.r_[1.0, np.arange(1.0, degree + 1)])
        # coef[span, k, r]: coefficient of dx^k in N_{span-p+r}
        self.coef = np.stack([taylor[k] / fact[k] for k in range(degree + 1)], axis=1)
        # the d-th derivative of dx^k is falling[d, k] dx^(k-d), falling[d, k] = k! / (k-d)!
        k_, d_ = np.meshgrid(np.arange(degree + 1), np.arange(degree + 1))
        self.falling = np.where(k_ >= d_, fact[k_] / fact[np.maximum(k_ - d_, 0)], 0.0)

    def spans(self, x: np.ndarray) -> np.ndarray:
        """Span of every x, never an empty one (a repeated knot at the domain's
        end would otherwise give the span [t, t) and a point of NaNs)."""
        return self.span_map[_find_spans(self.knots, self.p, self.n, x) - self.p]

    def __call__(self, spans: np.ndarray, x: np.ndarray, order: int) -> list[np.ndarray]:
        """``[N, N', ...]`` up to ``order``, each (n, p+1); column r is the
        function of index ``span - p + r``."""
        p = self.p
        C = np.take(self.coef, spans - p, axis=0)  # (m, k, r)
        dx = (x - self.knots[spans])[:, None]
        out = []
        for d in range(order + 1):
            if d > p:
                out.append(np.zeros((x.shape[0], p + 1)))
                continue
            f = self.falling[d]
            N = C[:, p] * f[p]  # Horner's scheme in dx
            for k in range(p - 1, d - 1, -1):
                N *= dx
                N += C[:, k] * f[k] if d else C[:, k]
            out.append(N)
        return out

    def _recurrence(self, spans: np.ndarray, x: np.ndarray, order: int) -> list[np.ndarray]:
        """The same as :meth:`__call__` by the Cox-de Boor recurrence and its
        derivative formula (used once, for the power-form coefficients)."""
        p, t = self.p, self.knots
        k = spans - p  # row into the tables
        m = x.shape[0]
        levels = [np.ones((m, 1))]  # levels[q][:, r] = N_{span-q+r, q}(x)
        for q in range(1, p + 1):
            prev = levels[-1]
            cur = np.zeros((m, q + 1))
            for r in range(q + 1):
                i = spans - q + r
                if r >= 1:
                    cur[:, r] += (x - t[i]) * self.left[q, r][k] * prev[:, r - 1]
                if r <= q - 1:
                    cur[:, r] += (t[i + q + 1] - x) * self.right[q, r][k] * prev[:, r]
            levels.append(cur)

        def deriv(q: int, d: int) -> np.ndarray:
            if d == 0:
                return levels[q]
            if d > q:
                return np.zeros((m, q + 1))
            lower = deriv(q - 1, d - 1)
            out = np.zeros((m, q + 1))
            for r in range(q + 1):
                if r >= 1:
                    out[:, r] += q * lower[:, r - 1] * self.left[q, r][k]
                if r <= q - 1:
                    out[:, r] -= q * lower[:, r] * self.right[q, r][k]
            return out

        return [deriv(p, d) for d in range(order + 1)]


def basis_functions(knots: np.ndarray, degree: int, spans: np.ndarray, x: np.ndarray,
                    order: int = 1) -> list[np.ndarray]:
    """Non-zero B-spline basis functions and their derivatives.

    Parameters
    ----------
    knots : (m,) float
    degree : int, p
    spans : (n,) int, knot span of each parameter (``knots[s] <= x < knots[s+1]``)
    x : (n,) float
    order : highest derivative wanted

    Returns
    -------
    list of (n, p+1) arrays ``[N, N', N'', ...]``; column r holds the function
    of index ``span - p + r``.
    """
    knots = np.asarray(knots, dtype=float)
    return _Basis(knots, degree, len(knots) - degree - 1)(np.asarray(spans), np.asarray(x, float), order)


@dataclass(frozen=True)
class SurfaceEval:
    """Surface quantities at n parameter points.

    xyz, su, sv : (n, 3) float
    normal : (n, 3) float, or None when normals were not asked for
    suu, suv, svv : (n, 3) float, or None when second derivatives were not asked for
    """

    xyz: np.ndarray
    su: np.ndarray
    sv: np.ndarray
    normal: np.ndarray | None
    suu: np.ndarray | None = None
    suv: np.ndarray | None = None
    svv: np.ndarray | None = None


class NurbsSurface:
    """A (possibly rational) tensor-product NURBS surface.

    Parameters
    ----------
    degree_u, degree_v : int
    knots_u : (nu + degree_u + 1,) float, non-decreasing
    knots_v : (nv + degree_v + 1,) float, non-decreasing
    ctrlpts : (nu, nv, 3) float, control point [i, j] at u-index i, v-index j
    weights : (nu, nv) float > 0, or None for a non-rational surface

    Raises :class:`SurfaceError` with a one-line message when the data do not
    define a surface.
    """

    def __init__(self, degree_u: int, degree_v: int, knots_u, knots_v, ctrlpts,
                 weights=None):
        for name, deg in (("degree_u", degree_u), ("degree_v", degree_v)):
            if isinstance(deg, bool) or not isinstance(deg, (int, np.integer)) or deg < 1:
                raise SurfaceError(f"{name} must be a positive integer, got {deg!r}")
        try:
            P = np.array(ctrlpts, dtype=float)
            ku = np.array(knots_u, dtype=float)
            kv = np.array(knots_v, dtype=float)
            W = None if weights is None else np.array(weights, dtype=float)
        except (TypeError, ValueError) as exc:
            raise SurfaceError(f"surface data are not numbers: {exc}") from None
        if P.ndim != 3 or P.shape[2] != 3:
            raise SurfaceError(f"control net must have shape (nu, nv, 3), got {P.shape}")
        nu, nv = P.shape[:2]
        if nu < degree_u + 1:
            raise SurfaceError(
                f"degree_u {degree_u} is too high for {nu} control points in u (needs at least {degree_u + 1})")
        if nv < degree_v + 1:
            raise SurfaceError(
                f"degree_v {degree_v} is too high for {nv} control points in v (needs at least {degree_v + 1})")
        for name, k, n, p in (("u", ku, nu, degree_u), ("v", kv, nv, degree_v)):
            if k.ndim != 1 or k.size != n + p + 1:
                raise SurfaceError(
                    f"knot vector {name} has {k.size} knots; {n} control points of degree {p} need {n + p + 1}")
            if not np.all(np.isfinite(k)):
                raise SurfaceError(f"knot vector {name} contains NaN or infinity")
            if np.any(np.diff(k) < 0):
                raise SurfaceError(f"knot vector {name} is not non-decreasing")
            if not k[p] < k[n]:
                raise SurfaceError(f"knot vector {name} defines an empty parameter domain")
            inner = k[1:-1]
            mult = np.max(np.unique(inner, return_counts=True)[1]) if inner.size else 0
            if mult > p + 1:
                raise SurfaceError(f"knot vector {name} has a knot of multiplicity {mult} > degree + 1")
        if not np.all(np.isfinite(P)):
            raise SurfaceError("control points contain NaN or infinity")
        if W is None:
            W = np.ones((nu, nv))
            self.rational = False
        else:
            if W.shape != (nu, nv):
                raise SurfaceError(f"weights have shape {W.shape}, control net needs {(nu, nv)}")
            if not np.all(np.isfinite(W)):
                raise SurfaceError("weights contain NaN or infinity")
            if np.any(W <= 0):
                raise SurfaceError("weights must be positive; found a weight <= 0")
            ratio = float(W.max() / W.min())
            if not ratio <= MAX_WEIGHT_RATIO:
                raise SurfaceError(f"weights range from {W.min():.3g} to {W.max():.3g}, a ratio of {ratio:.3g} "
                                   f"(at most {MAX_WEIGHT_RATIO:g}): the surface is numerically degenerate")
            self.rational = not np.all(W == W.flat[0])
        span = np.ptp(P.reshape(-1, 3), axis=0)
        scale = float(np.max(np.abs(P)))
        if not np.max(span) > 0:
            raise SurfaceError("all control points are equal: the surface is a single point")
        size = float(np.max(span) * np.linalg.norm(span / np.max(span)))  # no under- or overflow
        if not np.max(span) > 1e-12 * scale:
            raise SurfaceError(f"the control points differ by only {size:.3g} at coordinates up to {scale:.3g}: "
                               f"too little for double precision; move the surface near the origin")
        if size < MIN_SIZE:
            raise SurfaceError(f"the surface is too small to use: its control net is {size:.3g} across "
                               f"(at least {MIN_SIZE:g}), so it has no usable area; rescale the model")
        if size > MAX_SIZE:
            raise SurfaceError(f"the surface is too large to compute with: its control net is {size:.3g} across "
                               f"(at most {MAX_SIZE:g}), where lengths and energies overflow; rescale the model")
        self.degree_u = int(degree_u)
        self.degree_v = int(degree_v)
        self.knots_u = ku
        self.knots_v = kv
        self.ctrlpts = P
        self.weights = W
        # homogeneous control net (w x, w y, w z, w)
        self._pw = np.concatenate([P * W[..., None], W[..., None]], axis=2)
        self._pw_rows = self._pw.reshape(-1, 4)
        # flat offsets of a point's (p+1) x (q+1) support from its first control point
        self._support = (np.arange(self.degree_u + 1)[:, None] * nv + np.arange(self.degree_v + 1)[None, :]).ravel()
        self._basis_u = _Basis(ku, self.degree_u, nu)
        self._basis_v = _Basis(kv, self.degree_v, nv)
        for a in (self.knots_u, self.knots_v, self.ctrlpts, self.weights, self._pw, self._support):
            a.setflags(write=False)

    # ------------------------------------------------------------------ basic facts
    @property
    def shape(self) -> tuple[int, int]:
        """(nu, nv): control points in u and in v."""
        return self.ctrlpts.shape[:2]

    @property
    def domain(self) -> np.ndarray:
        """[[u0, u1], [v0, v1]], the parameter domain."""
        nu, nv = self.shape
        return np.array([[self.knots_u[self.degree_u], self.knots_u[nu]],
                         [self.knots_v[self.degree_v], self.knots_v[nv]]])

    def in_domain(self, uv: np.ndarray, tol: float = 0.0) -> np.ndarray:
        """(n,) bool: which (u, v) lie in the domain (within ``tol`` in parameter units)."""
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        d = self.domain
        return ((uv[:, 0] >= d[0, 0] - tol) & (uv[:, 0] <= d[0, 1] + tol)
                & (uv[:, 1] >= d[1, 0] - tol) & (uv[:, 1] <= d[1, 1] + tol))

    def bbox_diagonal(self) -> float:
        """Length of the control net's bounding-box diagonal (a size scale)."""
        P = self.ctrlpts.reshape(-1, 3)
        return float(np.linalg.norm(P.max(axis=0) - P.min(axis=0)))

    # ------------------------------------------------------------------ evaluation
    def _homogeneous(self, uv: np.ndarray, order: int) -> dict[tuple[int, int], np.ndarray]:
        """Homogeneous derivatives A^(a,b) (n, 4) for a + b <= order."""
        u, v = uv[:, 0], uv[:, 1]
        p, q = self.degree_u, self.degree_v
        nu, nv = self.shape
        su = self._basis_u.spans(u)
        sv = self._basis_v.spans(v)
        Nu = self._basis_u(su, u, order)
        Nv = self._basis_v(sv, v, order)
        # the support's control points by flat index: np.take of rows is ~8x faster than indexing the
        # (nu, nv, 4) net with two broadcast index arrays
        first = (su - p) * nv + (sv - q)
        G = np.take(self._pw_rows, first[:, None] + self._support, axis=0).reshape(-1, p + 1, q + 1, 4)
        out = {}
        for a in range(order + 1):
            # contract over the u-support once per a, then over v for each b
            Ga = np.einsum("na,nabc->nbc", Nu[a], G)
            for b in range(order + 1 - a):
                out[(a, b)] = np.einsum("nb,nbc->nc", Nv[b], Ga)
        return out

    def points(self, uv) -> np.ndarray:
        """(n, 3) points S(u, v) at uv : (n, 2)."""
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        A = self._homogeneous(uv, 0)[(0, 0)]
        return A[:, :3] / A[:, 3:4]

    def _rational(self, uv: np.ndarray, second: bool) -> tuple:
        """(S, S_u, S_v, S_uu, S_uv, S_vv) by the quotient rule on the homogeneous
        derivatives; the second derivatives are None unless asked for. Many points are
        evaluated in blocks of EVAL_BLOCK (the same numbers): each block's temporaries stay
        in the cache, 1.5 to 2x quicker at 640,000 points."""
        if len(uv) <= EVAL_BLOCK:
            return self._rational_block(uv, second)
        out = [np.empty((len(uv), 3)) for _ in range(6 if second else 3)]
        for i in range(0, len(uv), EVAL_BLOCK):
            for o, part in zip(out, self._rational_block(uv[i:i + EVAL_BLOCK], second)):
                o[i:i + EVAL_BLOCK] = part
        return tuple(out) + (() if second else (None, None, None))

    def _rational_block(self, uv: np.ndarray, second: bool) -> tuple:
        H = self._homogeneous(uv, 2 if second else 1)
        w = H[(0, 0)][:, 3:4]
        S = H[(0, 0)][:, :3] / w
        wu, wv = H[(1, 0)][:, 3:4], H[(0, 1)][:, 3:4]
        Su = (H[(1, 0)][:, :3] - wu * S) / w
        Sv = (H[(0, 1)][:, :3] - wv * S) / w
        if not second:
            return S, Su, Sv, None, None, None
        Suu = (H[(2, 0)][:, :3] - 2 * wu * Su - H[(2, 0)][:, 3:4] * S) / w
        Svv = (H[(0, 2)][:, :3] - 2 * wv * Sv - H[(0, 2)][:, 3:4] * S) / w
        Suv = (H[(1, 1)][:, :3] - wu * Sv - wv * Su - H[(1, 1)][:, 3:4] * S) / w
        return S, Su, Sv, Suu, Suv, Svv

    def derivatives(self, uv) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(S, S_u, S_v), each (n, 3), at uv : (n, 2), without normals (the cheap path)."""
        return self._rational(np.asarray(uv, dtype=float).reshape(-1, 2), False)[:3]

    def evaluate(self, uv, second: bool = False, normals: bool = True) -> SurfaceEval:
        """Points, partial derivatives and unit normals at uv : (n, 2).

        With ``second=True`` the second derivatives are filled in too. Where
        the surface is degenerate (a pole, where S_u or S_v vanishes) the normal
        is the limit normal from the interior. ``normals=False`` leaves them
        out (``normal`` is None), for callers that need only derivatives.
        """
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        S, Su, Sv, Suu, Suv, Svv = self._rational(uv, second)
        return SurfaceEval(S, Su, Sv, self._normals(uv, Su, Sv) if normals else None, Suu, Suv, Svv)

    def normals(self, uv, su: np.ndarray, sv: np.ndarray) -> np.ndarray:
        """(n, 3) unit normals at uv : (n, 2) from the first derivatives su, sv
        (n, 3) there (as :meth:`derivatives` gives them): the normals
        :meth:`evaluate` gives, for a caller that has the derivatives already."""
        return self._normals(np.asarray(uv, dtype=float).reshape(-1, 2), su, sv)

    def _normals(self, uv: np.ndarray, Su: np.ndarray, Sv: np.ndarray) -> np.ndarray:
        n = np.cross(Su, Sv)
        ln = np.linalg.norm(n, axis=1)
        lu = np.linalg.norm(Su, axis=1)
        lv = np.linalg.norm(Sv, axis=1)
        bad = ~(ln > 1e-7 * np.maximum(lu, lv) ** 2) | ~np.isfinite(ln)
        if np.any(bad):
            n[bad] = self._limit_normals(uv[bad])
            ln = np.linalg.norm(n, axis=1)
        return n / ln[:, None]

    def _limit_normals(self, uv: np.ndarray) -> np.ndarray:
        """Normals at degenerate points, as the limit from the domain's interior.

        At a pole on the edge u = u0 we have S_v(u0 + t, v) ~ t S_uv, so the
        normal is the direction of S_u x S_uv (signed by the side the interior
        lies on); likewise for the other edges. Points where that limit is
        degenerate too take the normal of a point moved a hair inward.
        """
        _, Su, Sv, _, Suv, _ = self._rational(uv, True)
        d = self.domain
        centre = d.mean(axis=1)
        n = np.zeros_like(Su)
        lu = np.linalg.norm(Su, axis=1)
        lv = np.linalg.norm(Sv, axis=1)
        v_degenerate = lv <= lu  # S_v vanishes: an edge u = const collapsed
        s_u = np.where(uv[:, 0] < centre[0], 1.0, -1.0)[:, None]
        s_v = np.where(uv[:, 1] < centre[1], 1.0, -1.0)[:, None]
        n_vd = np.cross(Su, Suv) * s_u
        n_ud = np.cross(Suv, Sv) * s_v
        n = np.where(v_degenerate[:, None], n_vd, n_ud)
        ln = np.linalg.norm(n, axis=1)
        scale = np.maximum(lu, lv) * np.linalg.norm(Suv, axis=1)
        still = ~(ln > 1e-9 * scale) | ~np.isfinite(ln)
        if np.any(still):
            h = 1e-7 * (d[:, 1] - d[:, 0])
            moved = uv[still] + h * np.sign(centre - uv[still])
            _, su, sv = self.derivatives(moved)
            n[still] = np.cross(su, sv)
        return n

    def __repr__(self) -> str:
        nu, nv = self.shape
        kind = "rational" if self.rational else "polynomial"
        return f"NurbsSurface({kind}, degree=({self.degree_u}, {self.degree_v}), ctrlpts=({nu}, {nv}))"


def boundary_distance(surface: NurbsSurface, uv: np.ndarray) -> np.ndarray:
    """(k,) distance of parameter points to the domain's boundary, in fractions of the domain."""
    dom = surface.domain
    t = (uv - dom[:, 0]) / np.ptp(dom, axis=1)
    return np.min(np.column_stack([t, 1 - t]), axis=1)
