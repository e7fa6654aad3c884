"""Pattern pieces ready to draw: the geometry every 2D exporter shares.

A :class:`Sheet` holds the pieces of a result in millimetres, laid out side
by side on one sheet, each with the lines a pattern maker expects:

* ``sew`` : the sew line, the pattern's outline (counter-clockwise, open
  polygon: first point not repeated), darts that open on the boundary walked
  round (the legs are stitching lines);
* ``cut`` : the cut line, the sew line offset outwards by the seam allowance
  (``None`` without one); mitred corners, bevelled beyond twice the width, so
  the allowance folds back onto the piece; a stretch of the outline may have
  its own width (a seam's allowance, ``build_sheet(allowances=...)``), the cut
  line stepping where the width changes;
* ``holes`` / ``hole_cuts`` : darts inside the piece (sew lines, and the
  allowance taken off inside them where anything is left);
* ``internal`` : dart legs and the tip, as drawn (not cut) lines;
* ``notches`` : short slits cut from the cut line towards the piece where a
  dart leg meets the outline, so the legs can be matched when sewing;
* ``drills`` : drill holes a little inside each dart tip;
* ``grain`` : the grain line, along the warp direction of the lattice, and
  its two arrow heads;
* ``system_text`` / ``annotation`` : the label: ASTM D6673's piece system
  text (``Piece Name: ...``, ``Quantity: 1``, ...) and free annotation lines
  (spacing, units, errors, date), placed in free space inside the piece
  (:func:`label_box`, ``TEXT_EM`` text heights per character, so CAD's
  wider stroke fonts fit too);
* ``offset`` : where the piece sits: sheet = result ``nodes.xy`` x
  ``Sheet.mm_per_unit`` + offset (mm), recorded in the DXF (the insertion
  point of the piece's block) and the SVG (``<metadata>``).

Offsetting is done by shapely (GEOS), the well-kept geometry library.
"""

from __future__ import annotations

import datetime as _dt
from dataclasses import dataclass, field, replace

import numpy as np

from flatweave.errors import SettingsError
from flatweave.method.lattice import WARP
from flatweave.geometry.numerics import nearest_segments, polygon_area, polyline_distance

__all__ = ["UNITS", "Sheet", "SheetPiece", "build_sheet", "mm_per_unit", "warp_direction", "label_box",
           "TEXT_EM", "LINE_PITCH", "SIZE", "QUANTITY", "join_sheets"]

UNITS = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4}
PIECE_GAP_MM = 30.0
NOTCH_MM = 6.0
DRILL_INSET_MM = 10.0
MITRE_LIMIT = 2.0
TEXT_EM = 1.0  # advance per character, in text heights: a bound for CAD's stroke fonts (LibreCAD's standard, txt)
LINE_PITCH = 1.6  # baseline to baseline, in text heights
LABEL_MARGIN = 1.0  # free space round a label, in text heights
MIN_LABEL_MM = 1.5
SIZE = "base"  # the pattern is not graded: one size, the base (sample) size
QUANTITY = 1


def mm_per_unit(units: str) -> float:
    """Millimetres in one model unit (mm, cm, m or in)."""
    try:
        return UNITS[units]
    except KeyError:
        raise SettingsError(f"unknown units {units!r}: use one of {', '.join(UNITS)}") from None


@dataclass(frozen=True)
class SheetPiece:
    """One pattern piece in millimetres, in sheet coordinates (y up)."""

    name: str
    sew: np.ndarray
    cut: np.ndarray | None
    holes: tuple = ()
    hole_cuts: tuple = ()
    internal: tuple = ()
    notches: tuple = ()
    drills: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    grain: np.ndarray = field(default_factory=lambda: np.zeros((2, 2)))
    grain_heads: tuple = ()
    system_text: tuple = ()
    annotation: tuple = ()
    label_at: np.ndarray = field(default_factory=lambda: np.zeros(2))
    label_height: float = 5.0
    offset: np.ndarray = field(default_factory=lambda: np.zeros(2))

    @property
    def label(self) -> tuple:
        """Every line of the label: the system text (``Key: value``), then the annotation."""
        return tuple(f"{k}: {v}" for k, v in self.system_text) + tuple(self.annotation)

    @property
    def outer(self) -> np.ndarray:
        """The outermost line: the cut line, or the sew line without an allowance."""
        return self.sew if self.cut is None else self.cut

    def bounds(self) -> np.ndarray:
        """[[xmin, ymin], [xmax, ymax]] of the outermost line."""
        o = self.outer
        return np.array([o.min(axis=0), o.max(axis=0)])

    def moved(self, d) -> "SheetPiece":
        """The piece translated by d (mm); its offset moves with it."""
        d = np.asarray(d, dtype=float)

        def mv(a):
            return None if a is None else np.asarray(a) + d

        return replace(self, sew=mv(self.sew), cut=mv(self.cut), holes=tuple(mv(h) for h in self.holes),
                       hole_cuts=tuple(mv(h) for h in self.hole_cuts), internal=tuple(mv(p) for p in self.internal),
                       notches=tuple(mv(p) for p in self.notches), drills=mv(self.drills), grain=mv(self.grain),
                       grain_heads=tuple(mv(p) for p in self.grain_heads), label_at=mv(self.label_at),
                       offset=mv(self.offset))


@dataclass(frozen=True)
class Sheet:
    """Every piece of a result, in mm, laid out left to right from (0, 0)."""

    pieces: tuple
    seam_allowance_mm: float
    units: str
    name: str = "piece"

    @property
    def mm_per_unit(self) -> float:
        """Millimetres per model unit: sheet = result xy x mm_per_unit + the piece's offset."""
        return mm_per_unit(self.units)

    @property
    def size(self) -> tuple[float, float]:
        """(width, height) in mm of the pieces' bounding box (which starts at 0, 0)."""
        b = np.array([p.bounds() for p in self.pieces])
        return float(b[:, 1, 0].max()), float(b[:, 1, 1].max())


def warp_direction(mesh, xy: np.ndarray, nodes: np.ndarray | None = None) -> np.ndarray:
    """Unit 2D direction of the warp threads (mean over the warp springs, oriented along +i)."""
    sel = mesh.kind == WARP
    a, b = mesh.ends[sel, 0], mesh.ends[sel, 1]
    if nodes is not None:
        inside = np.zeros(mesh.n_nodes, dtype=bool)
        inside[nodes] = True
        keep = inside[a] & inside[b]
        a, b = a[keep], b[keep]
    if len(a) == 0:
        return np.array([0.0, 1.0])
    flip = mesh.ij[b, 0] < mesh.ij[a, 0]
    a, b = np.where(flip, b, a), np.where(flip, a, b)
    d = (xy[b] - xy[a]).sum(axis=0)
    return d / np.linalg.norm(d)


def _polygon(sew, holes=()):
    from shapely.geometry import Polygon

    poly = Polygon(sew, [h for h in holes if len(h) >= 3])
    if not poly.is_valid:
        poly = poly.buffer(0)
    return poly


def _offset(sew: np.ndarray, holes, width: float):
    """Cut line and hole cut lines: the sew polygon grown by ``width`` mm."""
    from shapely.geometry import Polygon

    if width <= 0:
        return None, ()
    grown = _polygon(sew, holes).buffer(width, join_style="mitre", mitre_limit=MITRE_LIMIT)
    if grown.geom_type != "Polygon":  # keep the part holding the piece
        grown = max(grown.geoms, key=lambda g: g.area)
    assert isinstance(grown, Polygon)
    cut = np.asarray(grown.exterior.coords)[:-1]
    if polygon_area(cut) < 0:
        cut = cut[::-1]
    hole_cuts = tuple(np.asarray(r.coords)[:-1] for r in grown.interiors)
    return cut, hole_cuts


def _edge_widths(ring: np.ndarray, runs, default: float, reach: float) -> np.ndarray:
    """(n,) the allowance (mm) of each edge ring[i] -> ring[i + 1] of a closed ring: that of the
    run (a (k, 2) polyline, mm) its middle lies on, else ``default``."""
    w = np.full(len(ring), float(default))
    mids = 0.5 * (ring + np.roll(ring, -1, axis=0))
    for line, width in runs:
        if len(line) >= 2:
            w[polyline_distance(mids, np.asarray(line, dtype=float)) <= reach] = width
    return w


def _bands(ring: np.ndarray, widths: np.ndarray, floor: float) -> list:
    """Shapely shapes that grow ``ring`` (counter-clockwise round the cloth's outside, clockwise round a
    hole: its outside on the right) by each edge's width where it is above ``floor``: a one-sided band
    per run of equal width and, where two runs meet, the corner between them mitred (bevelled beyond
    MITRE_LIMIT widths)."""
    from shapely.geometry import LineString, Polygon

    n = len(ring)
    if n < 3 or not (widths > floor).any():
        return []
    # runs of equal width, started at a change (a ring of one width: two halves, so no run is a closed ring)
    change = np.flatnonzero(widths != np.roll(widths, 1))
    if len(change):
        order = np.roll(np.arange(n), -int(change[0]))
        runs = np.split(order, np.flatnonzero(np.diff(widths[order]) != 0) + 1)
    else:
        runs = [np.arange(n // 2), np.arange(n // 2, n)]
    out = []
    for run in runs:
        w = float(widths[run[0]])
        if w <= floor:
            continue
        pts = ring[np.r_[run, (run[-1] + 1) % n]]
        out.append(LineString(pts).buffer(-w, single_sided=True, join_style="mitre", mitre_limit=MITRE_LIMIT))
    for a, b in zip(runs, runs[1:] + runs[:1]):  # the corner where run a ends and run b starts
        wa, wb = float(widths[a[-1]]), float(widths[b[0]])
        if max(wa, wb) <= floor:
            continue
        c = ring[b[0]]
        ta, tb = ring[b[0]] - ring[a[-1]], ring[(b[0] + 1) % n] - ring[b[0]]
        ta, tb = ta / max(np.linalg.norm(ta), 1e-300), tb / max(np.linalg.norm(tb), 1e-300)
        na, nb = np.array([ta[1], -ta[0]]), np.array([tb[1], -tb[0]])  # right of the way round: outside
        pa, pb = c + wa * na, c + wb * nb
        # the two offset lines' meeting point, when they meet ahead of both ends within the mitre limit
        m = np.array([[ta[0], -tb[0]], [ta[1], -tb[1]]])
        corner = [c, pa, pb]
        if abs(np.linalg.det(m)) > 1e-9:
            s, t = np.linalg.solve(m, pb - pa)
            meet = pa + s * ta
            if s >= 0 >= t and np.linalg.norm(meet - c) <= MITRE_LIMIT * max(wa, wb):
                corner = [c, pa, meet, pb]
        poly = Polygon(corner)
        if poly.is_valid and poly.area > 0:
            out.append(poly)
    return out


def _offset_varied(sew: np.ndarray, holes, default: float, runs, reach: float):
    """Cut line and hole cut lines: the sew polygon grown by ``default`` mm, and by a run's own width
    along each of ``runs`` ((polyline mm, width mm), ...: the stretches of the outline or a hole with
    their own allowance)."""
    from shapely.geometry import Polygon
    from shapely.ops import unary_union

    rings = [sew] + [h[::-1] if polygon_area(h) > 0 else h for h in holes]  # holes clockwise
    widths = [_edge_widths(r, runs, default, reach) for r in rings]
    floor = min(float(w.min()) for w in widths)
    base = _polygon(sew, holes)
    parts = [base if floor <= 0 else base.buffer(floor, join_style="mitre", mitre_limit=MITRE_LIMIT)]
    for r, w in zip(rings, widths):
        parts += _bands(r, w, floor)
    grown = unary_union(parts)
    if grown.geom_type != "Polygon":
        grown = max(grown.geoms, key=lambda g: g.area)
    assert isinstance(grown, Polygon)
    if max(float(w.max()) for w in widths) <= 0:
        return None, ()
    cut = np.asarray(grown.exterior.coords)[:-1]
    if polygon_area(cut) < 0:
        cut = cut[::-1]
    return cut, tuple(np.asarray(r.coords)[:-1] for r in grown.interiors)


def _chord(poly, through: np.ndarray, direction: np.ndarray, length_frac: float = 0.7) -> np.ndarray:
    """The chord of ``poly`` along ``direction`` through a point, shortened to a fraction
    about its middle; a zero-length segment at the point if the line misses the piece."""
    from shapely.geometry import LineString

    b = np.asarray(poly.bounds, dtype=float)
    big = 4.0 * float(max(b[2] - b[0], b[3] - b[1]) + 1.0)
    chord = poly.intersection(LineString([through - big * direction, through + big * direction]))
    parts = [chord] if chord.geom_type == "LineString" else [g for g in getattr(chord, "geoms", [])
                                                             if g.geom_type == "LineString"]
    parts = [g for g in parts if not g.is_empty]
    if not parts:
        return np.array([through, through])
    line = max(parts, key=lambda g: g.length)
    p = np.asarray(line.coords)[[0, -1]]
    mid, half = p.mean(axis=0), 0.5 * length_frac * np.linalg.norm(p[1] - p[0])
    return np.array([mid - half * direction, mid + half * direction])


def label_box(at, lines, height: float, em: float = TEXT_EM) -> np.ndarray:
    """[[xmin, ymin], [xmax, ymax]] of a label: first baseline at ``at``, a line
    every ``LINE_PITCH`` heights, each character at most ``em`` heights wide;
    ascenders one height above the first baseline, descenders 0.3 below the last."""
    x, y = map(float, at)
    width = em * height * max((len(t) for t in lines), default=0)
    bottom = y - LINE_PITCH * height * (len(lines) - 1) - 0.3 * height
    return np.array([[x, bottom], [x + width, y + height]])


def _grain(poly, direction: np.ndarray, label: tuple, height: float) -> np.ndarray:
    """The grain line: a chord along the warp beside the point of the piece farthest
    from its outline, on the side with the longer chord, leaving room for the label."""
    from shapely.ops import polylabel

    b = np.asarray(poly.bounds, dtype=float)
    extent = float(max(b[2] - b[0], b[3] - b[1]))
    centre = np.asarray(polylabel(poly, tolerance=max(extent / 200.0, 1e-9)).coords[0])
    size = np.diff(label_box((0.0, 0.0), label, height), axis=0)[0]
    normal = np.array([direction[1], -direction[0]])
    shift = 0.5 * float(abs(size @ normal)) + 3.0 * height
    grain = max((_chord(poly, centre + sgn * shift * normal, direction) for sgn in (1.0, -1.0)),
                key=lambda g: np.linalg.norm(g[1] - g[0]))
    if np.linalg.norm(grain[1] - grain[0]) < 0.2 * extent:  # too little room beside the label
        grain = _chord(poly, centre, direction)
    return grain


def _place_label(poly, obstacles, label: tuple, height: float) -> tuple[np.ndarray, float]:
    """Where the label goes, and its height: the box (:func:`label_box`) grown by
    ``LABEL_MARGIN`` heights lies inside the piece and clear of ``obstacles`` (grain
    line, dart legs, drill holes), as far from both as it can; smaller text where
    nothing fits (down to ``MIN_LABEL_MM``). Returns (first baseline's start, height)."""
    import shapely
    from shapely.ops import polylabel

    b = np.asarray(poly.bounds, dtype=float)
    h = float(height)
    while True:
        m = LABEL_MARGIN * h
        free = poly.buffer(-m, join_style="mitre")
        if obstacles is not None and not obstacles.is_empty:
            free = free.difference(obstacles.buffer(m))
        (x0, y0), (x1, y1) = label_box((0.0, 0.0), label, h)
        w, t = x1 - x0, y1 - y0
        if not free.is_empty and w < b[2] - b[0] and t < b[3] - b[1]:
            nx = ny = 48
            xs = np.linspace(b[0], b[2] - w, nx)
            ys = np.linspace(b[1], b[3] - t, ny)
            X, Y = (g.ravel() for g in np.meshgrid(xs, ys))
            boxes = shapely.box(X, Y, X + w, Y + t)
            shapely.prepare(free)
            ok = shapely.contains(free, boxes)
            if ok.any():
                edge = free.boundary
                clear = shapely.distance(boxes[ok], edge)
                k = int(np.argmax(clear))
                X, Y = X[ok][k], Y[ok][k]
                return np.array([X - x0, Y - y0]), h
        if h * 0.8 < MIN_LABEL_MM:
            break
        h *= 0.8
    # nowhere free: centred on the point farthest from the outline
    extent = float(max(b[2] - b[0], b[3] - b[1]))
    centre = np.asarray(polylabel(poly, tolerance=max(extent / 200.0, 1e-9)).coords[0])
    (x0, y0), (x1, y1) = label_box((0.0, 0.0), label, h)
    return centre - 0.5 * np.array([x0 + x1, y0 + y1]), h


def _arrow_heads(grain: np.ndarray, size: float) -> tuple:
    d = grain[1] - grain[0]
    L = np.linalg.norm(d)
    if L == 0:
        return ()
    d = d / L
    n = np.array([-d[1], d[0]])
    heads = []
    for tip, back in ((grain[1], -d), (grain[0], d)):
        heads.append(np.array([tip + size * (back + 0.5 * n), tip, tip + size * (back - 0.5 * n)]))
    return tuple(heads)


def _nearest_edge(poly: np.ndarray, p: np.ndarray) -> tuple[int, float]:
    """The edge of the closed polygon ``poly`` nearest to p: (its index, the distance)."""
    k, d2 = nearest_segments(np.asarray(p, dtype=float).reshape(1, 2), np.vstack([poly, poly[:1]]))
    return int(k[0]), float(np.sqrt(d2[0]))


def _outward_normal(poly: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Outward unit normal of a CCW polygon at its point nearest to p (of a clockwise one, the
    inward: into a hole)."""
    k, _ = _nearest_edge(poly, p)
    e = np.roll(poly, -1, axis=0)[k] - poly[k]
    e = e / max(np.linalg.norm(e), 1e-300)
    return np.array([e[1], -e[0]])


def _ascii(text: str) -> str:
    """7-bit ASCII (ASTM D6673 files are ASCII): other characters become '?'."""
    return str(text).encode("ascii", errors="replace").decode("ascii")


def _label_text(name: str, style: str, result, units: str, seam_mm: float, metrics: dict,
                quantity: int = QUANTITY) -> tuple[tuple, tuple]:
    """(system text, annotation): ASTM D6673's piece system text as (key, value) pairs,
    and the lines a person reads (spacing, units, errors, date)."""
    s = result.settings
    mat = s.material
    spacing = f"{s.spacing:g}" if s.spacing_warp in (None, s.spacing) else f"{s.spacing:g} x {s.spacing_warp:g}"
    system = (
        ("Piece Name", name),
        ("Size", SIZE),
        ("Quantity", str(quantity)),
        ("Material", f"{mat.name or 'custom'} {mat.ratio}"),
        ("Category", style),
    )
    annotation = (
        f"spacing {spacing} {units}, weft angle {s.angle_deg:g} deg",
        f"units: mm (model in {units}), seam allowance {seam_mm:g} mm",
        f"boundary error {metrics.get('boundary_error_pct', float('nan')):.2f} %, "
        f"area error {metrics.get('area_error_pct', float('nan')):.2f} %",
        f"max shear {metrics.get('max_shear_deg', float('nan')):.1f} deg, "
        f"max thread strain {metrics.get('max_thread_strain_pct', float('nan')):.2f} %",
        f"shear warning {mat.warn_deg:g} deg, lock {mat.lock_deg:g} deg"
        + (f", {metrics['area_beyond_lock_pct']:.1f} % of the area beyond lock"
           if "area_beyond_lock_pct" in metrics else ""),
        f"flatweave {_dt.date.today().isoformat()}",
    )
    return tuple((k, _ascii(v)) for k, v in system), tuple(map(_ascii, annotation))


def build_sheet(result, units: str = "m", seam_allowance_mm: float = 10.0, name: str = "piece",
                quantity: int = QUANTITY, sew_notches=(), allowances=()) -> Sheet:
    """The pieces of a :class:`flatweave.method.pipeline.FlattenResult` in mm, with all their lines;
    ``quantity``: how many of it are cut (the labels' ``Quantity``); ``sew_notches``: (point, unit
    direction of the sew line there) of the pattern (model units) on a piece's outline or region
    hole where a notch is cut (a seam's match points: :func:`flatweave.method.seams.flat_notches`),
    each a slit across the sew line from the cut line towards the piece, as at a dart's mouth;
    ``allowances``: (stretch of the outline or a region hole (k, 2), model units; its seam
    allowance, mm), the stretches whose allowance is not ``seam_allowance_mm`` (a seam's own)."""
    if not np.isfinite(seam_allowance_mm) or seam_allowance_mm < 0:
        raise SettingsError(f"seam allowance {seam_allowance_mm!r} mm must be zero or a positive number")
    for _, width in allowances:
        if not np.isfinite(width) or width < 0:
            raise SettingsError(f"seam allowance {width!r} mm must be zero or a positive number")
    scale = mm_per_unit(units)
    pat = result.pattern
    xy_mm = pat.xy * scale
    pieces_src = pat.pieces if pat.pieces else ()
    if not pieces_src:
        raise SettingsError("the result has no pattern piece to export")
    many = len(pieces_src) > 1
    pieces = []
    for k, src in enumerate(pieces_src):
        pname = _ascii(f"{name} {k + 1}" if many else name)
        sew = np.asarray(src.outline, dtype=float) * scale
        if polygon_area(sew) < 0:
            sew = sew[::-1]
        holes = tuple(np.asarray(h, dtype=float) * scale for h in src.holes)
        reach = 1e-6 * max(float(np.ptp(sew, axis=0).max()), 1e-300)
        runs = [(np.asarray(line, dtype=float) * scale, float(w)) for line, w in allowances]
        if runs:
            widths = np.concatenate([_edge_widths(r, runs, seam_allowance_mm, reach) for r in (sew, *holes)])
        if runs and (widths != seam_allowance_mm).any():
            cut, hole_cuts = _offset_varied(sew, holes, seam_allowance_mm, runs, reach)
        else:
            cut, hole_cuts = _offset(sew, holes, seam_allowance_mm)
        outer = sew if cut is None else cut
        # darts of this piece: legs that lie on its sew line or inside it
        internal, notches, drills = [], [], []
        from shapely.geometry import Point

        region = _polygon(outer)
        for dart in pat.darts:
            for leg in (dart.leg_a, dart.leg_b):
                leg = np.asarray(leg) * scale
                if not region.buffer(1.0).contains(Point(leg[len(leg) // 2])):
                    continue
                internal.append(leg)
                if dart.mouth:
                    n = _outward_normal(sew, leg[0])
                    start = leg[0] + seam_allowance_mm * n
                    notches.append(np.array([start, start - NOTCH_MM * n]))
            tip = 0.5 * (dart.leg_a[-1] + dart.leg_b[-1]) * scale
            if region.contains(Point(tip)):
                # a drill hole on the dart's centre line, inside the tip
                mouth = 0.5 * (dart.leg_a[0] + dart.leg_b[0]) * scale
                axis = mouth - tip
                L = np.linalg.norm(axis)
                inset = min(DRILL_INSET_MM, 0.25 * L) if dart.mouth else 0.0
                drills.append(tip + (axis / L * inset if L > 0 else 0.0))
        cloth = _polygon(sew, holes[:src.n_region_holes])
        for q, along in sew_notches:
            q = np.asarray(q, dtype=float) * scale
            if not any(_nearest_edge(ring, q)[1] <= reach for ring in (sew, *holes[:src.n_region_holes])):
                continue  # another piece's
            n = np.array([along[1], -along[0]], dtype=float)  # across the sew line, away from the cloth
            if cloth.contains(Point(q + 1e-3 * float(np.ptp(sew, axis=0).max()) * n)):
                n = -n
            width = seam_allowance_mm
            for line, w in runs:  # the notch's own stretch's allowance: the slit starts on its cut line
                if polyline_distance(q[None], line)[0] <= reach:
                    width = w
            start = q + width * n
            slit = np.array([start, start - NOTCH_MM * n])
            if not any(np.abs(slit - o).max() <= 1e-6 for o in notches):  # two sew lines ending where one did
                notches.append(slit)
        direction = warp_direction(result.mesh, xy_mm, src.nodes if len(src.nodes) else None)
        extent = float(np.ptp(sew, axis=0).max())
        label_h = float(np.clip(0.012 * extent, 2.5, 8.0))
        system, annotation = _label_text(pname, name, result, units, seam_allowance_mm, result.metrics, quantity)
        label = tuple(f"{k}: {v}" for k, v in system) + annotation
        poly = _polygon(sew, holes)
        grain = _grain(poly, direction, label, label_h)
        heads = _arrow_heads(grain, size=min(15.0, 0.04 * extent + 2.0))
        from shapely.geometry import LineString, MultiPoint
        from shapely.ops import unary_union

        marks = [LineString(grain)] + [LineString(hd) for hd in heads] + [LineString(g) for g in internal]
        marks += [LineString(n) for n in notches] + ([MultiPoint(drills)] if drills else [])
        label_at, label_h = _place_label(poly, unary_union(marks), label, label_h)
        pieces.append(SheetPiece(pname, sew, cut, holes, hole_cuts, tuple(internal), tuple(notches),
                                 np.array(drills).reshape(-1, 2), grain, heads, system, annotation, label_at,
                                 label_h))
    return Sheet(_side_by_side(pieces), float(seam_allowance_mm), units, _ascii(name))


def _side_by_side(pieces) -> tuple:
    """The pieces laid out left to right, bottoms on y = 0, ``PIECE_GAP_MM`` apart; each
    piece's offset says how far it moved."""
    placed, x = [], 0.0
    for p in pieces:
        lo, hi = p.bounds()
        placed.append(p.moved([x - lo[0], -lo[1]]))
        x += (hi[0] - lo[0]) + PIECE_GAP_MM
    return tuple(placed)


def join_sheets(sheets, name: str) -> Sheet:
    """One sheet of the pieces of ``sheets`` (a project's pieces, each built by
    :func:`build_sheet` with its own name), laid out side by side: a DXF of it holds a
    block per piece. The sheets share their units and seam allowance (ValueError if not)."""
    sheets = list(sheets)
    if not sheets:
        raise SettingsError("there is no solved piece to export")
    if len({(s.units, s.seam_allowance_mm) for s in sheets}) > 1:
        raise ValueError("joined sheets must share their units and seam allowance")
    return Sheet(_side_by_side([p for s in sheets for p in s.pieces]), sheets[0].seam_allowance_mm,
                 sheets[0].units, _ascii(name))
