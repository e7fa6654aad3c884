"""Area and bounding box of a trimmed region of a NURBS surface.

A region is given by polygons in the surface's (u, v) domain: an outer loop
and holes (as :class:`flatweave.reading.cad.CadFace` carries them; any orientation, the
holes are what lies inside the outer loop and inside a hole). Its area on the
surface is

    A = integral over the region of J(u, v) du dv,   J = |S_u x S_v|.

:func:`region_area` computes it by Green's theorem on each knot-span cell
separately: inside a cell the surface is one rational polynomial piece, so J
is smooth there. With the region cut to the cell (shapely), and
F(u, v) = integral of J(s, v) ds from the cell's left edge u_c to u,

    integral over the piece of J du dv = loop integral of F dv

around the piece's boundary (exterior counter-clockwise, holes clockwise).
Each boundary segment is split into pieces no longer than an eighth of the
cell and integrated by Gauss-Legendre with ``n_boundary`` nodes; F at each
node by Gauss-Legendre with ``n_inner`` nodes on [u_c, u]. Both integrands
are smooth on their intervals, so the error falls geometrically with the
number of nodes; the polygon itself is the region (how closely it follows
curved trims is the sampler's business). All surface evaluations are one
vectorised :meth:`NurbsSurface.derivatives` call per block of points.
"""

from __future__ import annotations

import numpy as np

from flatweave.geometry.nurbs import NurbsSurface
from flatweave.geometry.quadrature import gauss_legendre_01, span_breaks

__all__ = ["region_polygon", "region_area", "region_bbox"]

_BLOCK = 60_000  # points per surface evaluation (the basis gather takes ~0.5 kB a point)


def region_polygon(loops):
    """A valid shapely (Multi)Polygon of the region: outer loop ``loops[0]``
    minus every further loop (holes)."""
    import shapely

    outer = shapely.make_valid(shapely.Polygon(np.asarray(loops[0], float)))
    holes = [shapely.make_valid(shapely.Polygon(np.asarray(h, float))) for h in loops[1:] if len(h) >= 3]
    region = outer
    if holes:
        region = shapely.difference(outer, shapely.union_all(holes))
    return region


def _polygons(geom):
    """The polygons of a shapely geometry (a cut can give lines and points too)."""
    import shapely

    out = []
    for part in shapely.get_parts(geom):
        if part.geom_type == "Polygon" and not part.is_empty:
            out.append(part)
        elif part.geom_type in ("MultiPolygon", "GeometryCollection"):
            out.extend(_polygons(part))
    return out


def _rings(poly) -> list[np.ndarray]:
    """Closed rings (first point repeated at the end) of a polygon: exterior
    counter-clockwise, interiors clockwise."""
    from shapely.geometry.polygon import orient

    p = orient(poly, 1.0)
    return [np.asarray(p.exterior.coords)] + [np.asarray(r.coords) for r in p.interiors]


def _jacobian(surface: NurbsSurface, uv: np.ndarray) -> np.ndarray:
    out = np.empty(len(uv))
    for k in range(0, len(uv), _BLOCK):
        _, su, sv = surface.derivatives(uv[k:k + _BLOCK])
        out[k:k + _BLOCK] = np.linalg.norm(np.cross(su, sv), axis=1)
    return out


def region_area(surface: NurbsSurface, loops, n_boundary: int = 8, n_inner: int = 16) -> float:
    """Area on ``surface`` of the (u, v) region bounded by ``loops`` (outer
    loop first, then holes; (n, 2) arrays, closed implicitly or explicitly).

    Accurate to about 1e-14 relative for the polygon region (measured on the
    bundled examples' whole domains against their independent reference
    areas; with 6 and 10 nodes a single-span dome and saddle were off by
    1e-10); see the module docstring. Segments shorter than 1/256 of their
    cell (a densely sampled curve) take two boundary nodes.
    """
    import shapely

    region = region_polygon(loops)
    if region.is_empty:
        return 0.0
    nu, nv = surface.shape
    bu = span_breaks(surface.knots_u, surface.degree_u, nu)
    bv = span_breaks(surface.knots_v, surface.degree_v, nv)
    # only the cells the region's box touches (the loops are clipped to the domain)
    x0, y0, x1, y1 = region.bounds
    iu = np.arange(max(0, np.searchsorted(bu, x0, "right") - 1), min(len(bu) - 1, np.searchsorted(bu, x1, "left")))
    iv = np.arange(max(0, np.searchsorted(bv, y0, "right") - 1), min(len(bv) - 1, np.searchsorted(bv, y1, "left")))
    I, K = np.meshgrid(iu, iv, indexing="ij")
    I, K = I.ravel(), K.ravel()
    boxes = shapely.box(bu[I], bv[K], bu[I + 1], bv[K + 1])
    pieces = shapely.intersection(region, boxes)

    xb, wb = gauss_legendre_01(n_boundary)
    xi, wi = gauss_legendre_01(n_inner)
    starts, ends, left, hmax = [], [], [], []
    for cell, piece in enumerate(pieces):
        if piece.is_empty:
            continue
        size = max(bu[I[cell] + 1] - bu[I[cell]], bv[K[cell] + 1] - bv[K[cell]])
        for poly in _polygons(piece):
            for ring in _rings(poly):
                a, b = ring[:-1], ring[1:]
                moving = b[:, 1] != a[:, 1]  # segments with dv = 0 add nothing
                starts.append(a[moving])
                ends.append(b[moving])
                left.append(np.full(int(moving.sum()), bu[I[cell]]))
                hmax.append(np.full(int(moving.sum()), size / 8.0))
    if not starts:
        return 0.0
    a, b = np.vstack(starts), np.vstack(ends)
    uc, hmax = np.concatenate(left), np.concatenate(hmax)
    # split long segments into pieces no longer than hmax
    m = np.maximum(1, np.ceil(np.linalg.norm(b - a, axis=1) / hmax).astype(int))
    seg = np.repeat(np.arange(len(a)), m)
    k = np.arange(len(seg)) - np.repeat(np.cumsum(m) - m, m)
    t0 = (k / m[seg])[:, None]
    t1 = ((k + 1) / m[seg])[:, None]
    pa = a[seg] + t0 * (b[seg] - a[seg])
    pb = a[seg] + t1 * (b[seg] - a[seg])
    uc, hmax = uc[seg], hmax[seg]
    # short pieces (most of a densely sampled curve) need only two boundary nodes
    short = np.linalg.norm(pb - pa, axis=1) <= hmax / 32.0
    total = 0.0
    for group, (x, w) in ((short, gauss_legendre_01(2)), (~short, (xb, wb))):
        if np.any(group):
            total += _green(surface, pa[group], pb[group], uc[group], x, w, xi, wi)
    return float(total)


def _green(surface, pa, pb, uc, xb, wb, xi, wi) -> float:
    """Sum over segments pa -> pb of the integral of F dv, F from uc."""
    # boundary nodes: (pieces, nodes)
    u = pa[:, None, 0] + xb[None, :] * (pb[:, None, 0] - pa[:, None, 0])
    v = pa[:, None, 1] + xb[None, :] * (pb[:, None, 1] - pa[:, None, 1])
    dv = (pb[:, 1] - pa[:, 1])[:, None] * wb[None, :]
    # inner nodes on [uc, u]: (pieces, nodes, n_inner)
    width = u - uc[:, None]
    s = uc[:, None, None] + width[:, :, None] * xi[None, None, :]
    uv = np.column_stack([s.ravel(), np.broadcast_to(v[:, :, None], s.shape).ravel()])
    J = _jacobian(surface, uv).reshape(s.shape)
    F = width * np.einsum("pbi,i->pb", J, wi)
    return float(np.sum(F * dv))


def _densify(loops, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Every loop's closed polyline with segments longer than step cut into
    equal pieces: (points, next) where next[i] is the index of the point
    after point i along its loop."""
    pts, nxt, base = [], [], 0
    for loop in loops:
        p = np.asarray(loop, float)
        if len(p) > 1 and np.all(p[-1] == p[0]):
            p = p[:-1]
        q = np.roll(p, -1, axis=0)
        m = np.maximum(1, np.ceil(np.linalg.norm(q - p, axis=1) / step).astype(int))
        seg = np.repeat(np.arange(len(p)), m)
        k = np.arange(len(seg)) - np.repeat(np.cumsum(m) - m, m)
        t = (k / m[seg])[:, None]
        d = p[seg] + t * (q[seg] - p[seg])
        pts.append(d)
        nxt.append(base + (np.arange(len(d)) + 1) % len(d))
        base += len(d)
    return np.vstack(pts), np.concatenate(nxt)


def region_bbox(surface: NurbsSurface, loops) -> tuple:
    """(xmin, ymin, zmin, xmax, ymax, zmax) of the surface over the (u, v)
    region bounded by ``loops`` (outer loop first, then holes).

    Each extreme is the better of the boundary's and the interior's. The
    boundary polyline (long segments cut to 1/64 of the region's size) and a
    48 x 48 grid of interior points are evaluated; then the best boundary
    sample of each extreme is polished along its two segments (four rounds
    of 17 points, each zooming 8-fold) and the best interior sample by Newton
    steps on the coordinate's gradient (kept only where it stays in the
    region and improves). All six extremes are polished together, a few
    vectorised evaluations in all. Agrees with the analytic box of spheres
    and tori to about 1e-12.
    """
    import shapely

    region = region_polygon(loops)
    x0, y0, x1, y1 = region.bounds
    diag = float(np.hypot(x1 - x0, y1 - y0)) or 1.0
    B, nxt = _densify(loops, diag / 64.0)
    prv = np.empty_like(nxt)
    prv[nxt] = np.arange(len(nxt))
    U, V = np.meshgrid(np.linspace(x0, x1, 50)[1:-1], np.linspace(y0, y1, 50)[1:-1], indexing="ij")
    grid = np.column_stack([U.ravel(), V.ravel()])
    inner = grid[shapely.contains_xy(region, grid[:, 0], grid[:, 1])]
    PB = surface.points(B)
    coord = np.repeat(np.arange(3), 2)           # extreme e is of coordinate coord[e] ...
    sign = np.tile([1.0, -1.0], 3)               # ... minimising sign[e] * x (min, then max)
    best = np.min(sign[None, :] * PB[:, coord], axis=0)  # (6,) best values of sign * x

    # along the boundary: both segments at each extreme's best sample
    i = np.argmin(sign[None, :] * PB[:, coord], axis=0)
    seg_a = np.concatenate([B[prv[i]], B[i]])    # (12, 2): 6 segments before, 6 after
    seg_b = np.concatenate([B[i], B[nxt[i]]])
    e12 = np.tile(np.arange(6), 2)
    lo_t, hi_t = np.zeros(12), np.ones(12)
    ts = np.linspace(0.0, 1.0, 17)
    for _ in range(4):
        t = lo_t[:, None] + (hi_t - lo_t)[:, None] * ts[None, :]        # (12, 17)
        uv = seg_a[:, None, :] + t[..., None] * (seg_b - seg_a)[:, None, :]
        X = surface.points(uv.reshape(-1, 2)).reshape(12, 17, 3)
        f = sign[e12][:, None] * X[np.arange(12)[:, None], np.arange(17)[None, :], coord[e12][:, None]]
        k = np.argmin(f, axis=1)
        np.minimum.at(best, e12, f[np.arange(12), k])
        width = (hi_t - lo_t) / 16.0
        tk = t[np.arange(12), k]
        lo_t, hi_t = np.maximum(0.0, tk - width), np.minimum(1.0, tk + width)

    # inside: Newton on the gradient of sign * x_k from the best grid point
    if len(inner):
        PI = surface.points(inner)
        x = inner[np.argmin(sign[None, :] * PI[:, coord], axis=0)].copy()   # (6, 2)
        dom = surface.domain
        for _ in range(25):
            ev = surface.evaluate(x, second=True, normals=False)
            r = np.arange(6)
            g = sign[:, None] * np.column_stack([ev.su[r, coord], ev.sv[r, coord]])
            H = sign[:, None, None] * np.stack([
                np.column_stack([ev.suu[r, coord], ev.suv[r, coord]]),
                np.column_stack([ev.suv[r, coord], ev.svv[r, coord]])], axis=1)
            det = H[:, 0, 0] * H[:, 1, 1] - H[:, 0, 1] ** 2
            ok = (det > 1e-14 * np.maximum(np.abs(H).max(axis=(1, 2)), 1e-300) ** 2) & (H[:, 0, 0] > 0)
            step = np.zeros_like(x)
            step[ok] = np.linalg.solve(H[ok], g[ok][..., None])[..., 0]
            x = np.clip(x - step, dom[:, 0], dom[:, 1])
            if not np.any(ok) or np.max(np.abs(step)) <= 1e-15 * diag:
                break
        inside = shapely.contains_xy(region, x[:, 0], x[:, 1])
        f = sign * surface.points(x)[np.arange(6), coord]
        best = np.where(inside, np.minimum(best, f), best)
    value = sign * best
    return tuple(float(v) for v in np.r_[value[0::2], value[1::2]])
