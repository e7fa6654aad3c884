"""Nesting: pieces placed on a roll as short as it can be (issue 43).

A marker is every piece's cut outline, times its quantity, placed on a roll of
a given width without overlapping, as short along the roll as the time given
allows. The placing is sparrow's (Gardeyn and Wauters' strip-packing heuristic,
through its Python bindings, spyrrow): a nesting engine, not a packer of our own.
What is ours is the conversion: outlines in millimetres, each turned first so
its grain (the warp) runs along the roll (x: along the roll, y: across it, 0 to
the roll's width), the rotations a piece may take from there (``grain``: 0 and
180 degrees, ``one-way``: 0 only, a napped or one-way material; ``free``: any,
an isotropic sheet), the gap kept between pieces, an outline simplified only
outwards (the polygon placed contains the cut outline, so the cut outlines keep
the gap), and the marker read back in each piece's own frame.

The solve runs in a child process: its progress (every better marker sparrow
finds) comes back as it is found (``on_progress``), and a stop ends it at once,
keeping the best marker so far (sparrow's solve cannot be interrupted in
process); a native crash there is one line, not the caller's end.
"""

from __future__ import annotations

import math
import os
import queue as queue_module
import time
from dataclasses import dataclass, field

import numpy as np

from flatweave.errors import FlatweaveError, SettingsError
from flatweave.geometry.numerics import polygon_area, rotate
from flatweave.studies.sweep import pool_context

__all__ = ["NestItem", "Placement", "Marker", "nest", "ROTATIONS", "SIMPLIFY_MM", "marker_problems",
           "min_width", "DEFAULT_SECONDS", "outline_margin", "usable_width"]

ROTATIONS = {"grain": (0.0, 180.0), "one-way": (0.0,), "free": None}
"""How a piece may turn on the roll from its grain along it: a woven piece keeps its grain (0 or 180
degrees), a napped or one-way one its direction too (0), an isotropic one any way (None)."""
SIMPLIFY_MM = 0.25
"""The cut outline is grown by this much (or by a ten-thousandth of the roll's width, if less) before it
is simplified by as much, for the engine: the polygon placed then holds the outline, which is never cut
into; a marker is that much longer at most."""
DEFAULT_SECONDS = 30.0
POLL = 0.2  # seconds between looks at the child's progress


def outline_margin(roll_width: float) -> float:
    """How much the engine's polygon stands outside a cut outline (mm): :data:`SIMPLIFY_MM`, or a
    ten-thousandth of the roll's width if less."""
    return min(SIMPLIFY_MM, 1e-4 * roll_width)


def usable_width(roll_width: float) -> float:
    """The width across the roll a cut outline may take (mm): the roll's less the margin either side."""
    return roll_width - 2.0 * outline_margin(roll_width)


@dataclass(frozen=True)
class NestItem:
    """One piece to place.

    name : its label (unique among the items)
    outline : (k, 2) its cut outline in millimetres, in its own frame (a pattern piece's outline x mm)
    quantity : copies to place
    grain_deg : the direction of its warp in its own frame (degrees from +x): turned by -grain_deg the
        warp runs along the roll
    rotations : a key of :data:`ROTATIONS`, or the angles (degrees, from the grain along the roll) it may take
    mirror : cut in mirror pairs (a left and a right panel): of its copies, the last ``quantity // 2`` are its
        mirror image (its frame's x negated; an odd quantity has one more as drawn)
    """

    @property
    def turns(self) -> tuple | None:
        """The angles it may take from its grain along the roll (None: any)."""
        return ROTATIONS[self.rotations] if isinstance(self.rotations, str) else self.rotations

    name: str
    outline: np.ndarray
    quantity: int = 1
    grain_deg: float = 90.0
    rotations: str = "grain"
    mirror: bool = False

    def __post_init__(self):
        outline = np.asarray(self.outline, dtype=float)
        if outline.ndim != 2 or outline.shape[1] != 2 or len(outline) < 3 or not np.isfinite(outline).all():
            raise SettingsError(f"piece {self.name!r}: its outline must be three or more finite points")
        if abs(polygon_area(outline)) <= 0:
            raise SettingsError(f"piece {self.name!r}: its outline has no area")
        object.__setattr__(self, "outline", outline)
        if isinstance(self.quantity, bool) or not isinstance(self.quantity, int) or self.quantity < 1:
            raise SettingsError(f"piece {self.name!r}: its quantity must be a whole number from 1, "
                                f"got {self.quantity!r:.40}")
        if isinstance(self.rotations, str):
            if self.rotations not in ROTATIONS:
                raise SettingsError(f"rotations must be one of {', '.join(ROTATIONS)}, got {self.rotations!r:.40}")
        else:
            try:
                turns = tuple(float(a) for a in self.rotations)
            except (TypeError, ValueError):
                turns = ()
            if not turns or not all(math.isfinite(a) for a in turns):
                raise SettingsError(f"piece {self.name!r}: its rotations must be a name ({', '.join(ROTATIONS)}) "
                                    f"or a list of angles in degrees")
            object.__setattr__(self, "rotations", turns)
        if not math.isfinite(self.grain_deg):
            raise SettingsError(f"piece {self.name!r}: its grain direction must be a finite angle")
        if not isinstance(self.mirror, bool):
            raise SettingsError(f"piece {self.name!r}: mirror pairs are on or off (True or False)")

    @property
    def drawn(self) -> int:
        """How many of its copies are cut as drawn (the others mirrored)."""
        return self.quantity - self.quantity // 2 if self.mirror else self.quantity

    def copy_mirrored(self, copy: int) -> bool:
        """Whether copy ``copy`` (from 0) is the mirror image."""
        return copy >= self.drawn

    @property
    def area(self) -> float:
        """The cut outline's area, mm^2."""
        return abs(polygon_area(self.outline))


@dataclass(frozen=True)
class Placement:
    """One copy placed: item ``item`` (index into the marker's items), copy ``copy`` (from 0),
    its outline mapped (``mirrored``: first reflected, its frame's x negated) by a rotation of
    ``rotation_deg`` about its frame's origin and then the translation (``x``, ``y``) mm."""

    item: int
    copy: int
    rotation_deg: float
    x: float
    y: float
    mirrored: bool = False

    def place(self, points: np.ndarray) -> np.ndarray:
        """``points`` (k, 2) of the item's frame on the roll."""
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        return rotate(p * np.array([-1.0, 1.0]) if self.mirrored else p, self.rotation_deg) + np.array([self.x, self.y])


@dataclass(frozen=True)
class Marker:
    """A nesting: the ``items``, their ``placements``, the roll's width and the marker's length (mm),
    the gap kept, how long it took, and whether it was stopped before its time was up (the best so far)."""

    items: tuple
    placements: tuple
    roll_width: float
    length: float
    gap: float = 0.0
    seconds: float = 0.0
    stopped: bool = False
    reports: int = field(default=0, compare=False)

    @property
    def pieces_area(self) -> float:
        """Every placed copy's cut outline area, mm^2."""
        return float(sum(self.items[p.item].area for p in self.placements))

    @property
    def utilisation(self) -> float:
        """The pieces' area over the roll's area used (length x width), 0 to 1."""
        used = self.length * self.roll_width
        return self.pieces_area / used if used > 0 else 0.0

    @property
    def waste(self) -> float:
        """The roll's area used but not cut into pieces, mm^2."""
        return self.length * self.roll_width - self.pieces_area

    def outlines(self) -> list[np.ndarray]:
        """Each placement's cut outline on the roll, in the placements' order."""
        return [p.place(self.items[p.item].outline) for p in self.placements]


def min_width(outline: np.ndarray, rotations: str, grain_deg: float) -> float:
    """The least width across the roll ``outline`` takes in the rotations allowed (mm)."""
    p = np.asarray(outline, dtype=float)
    turns = ROTATIONS[rotations] if isinstance(rotations, str) else rotations
    if turns is None:
        angles = np.radians(np.arange(0.0, 180.0, 0.5))
    else:  # (a turn by 180 degrees spans the same width)
        angles = np.radians([a - grain_deg for a in turns])
    y = np.sin(angles)[:, None] * p[None, :, 0] + np.cos(angles)[:, None] * p[None, :, 1]
    return float(np.min(y.max(axis=1) - y.min(axis=1)))


def _engine_shape(outline: np.ndarray, grain_deg: float, grow: float) -> list[tuple[float, float]]:
    """The outline as the engine places it: turned so the warp runs along +x, grown by ``grow`` and
    simplified by as much (so it holds the outline), counter-clockwise, its first point not repeated."""
    from shapely.geometry import Polygon
    from shapely.geometry.polygon import orient

    poly = Polygon(rotate(outline, -grain_deg))
    if not poly.is_valid:
        poly = poly.buffer(0)
    if poly.geom_type != "Polygon":
        poly = max(poly.geoms, key=lambda g: g.area)
    grown = poly.buffer(grow, join_style="mitre", mitre_limit=2.0).simplify(grow)
    grown = orient(grown, 1.0)
    return [tuple(map(float, q)) for q in np.asarray(grown.exterior.coords)[:-1]]


def _check(items, roll_width: float, gap: float, seconds: float) -> None:
    if isinstance(roll_width, bool) or not isinstance(roll_width, (int, float)) or not math.isfinite(roll_width) \
            or roll_width <= 0:
        raise SettingsError(f"the roll's width must be a positive length in mm, got {roll_width!r:.40}")
    if isinstance(gap, bool) or not isinstance(gap, (int, float)) or not math.isfinite(gap) or gap < 0:
        raise SettingsError(f"the gap between pieces must be zero or a positive length in mm, got {gap!r:.40}")
    if isinstance(seconds, bool) or not isinstance(seconds, (int, float)) or not math.isfinite(seconds) \
            or not 0 < seconds <= 24 * 3600:
        raise SettingsError(f"the time limit must be a positive number of seconds up to a day, got {seconds!r:.40}")
    if not items:
        raise SettingsError("there is no piece to nest")
    names = [it.name for it in items]
    if len(set(names)) != len(names):
        raise SettingsError("two pieces to nest have the same name")
    for it in items:
        w = min_width(it.outline, it.rotations, it.grain_deg)
        if w > usable_width(roll_width):
            how = "in any rotation" if it.turns is None else "in the rotations its grain allows"
            raise SettingsError(f"piece {it.name!r} is {w:.1f} mm across the roll {how}, wider than the roll "
                                f"({roll_width:g} mm): it must be spliced into parts, or cut from a wider roll")


def _child(job: dict, out) -> None:
    """The solve, in a child process: every better feasible marker put on ``out`` as it is found,
    then ("final", marker) or ("error", one line)."""
    import threading

    try:
        import spyrrow

        items = [spyrrow.Item(str(k), shape, qty, rot) for k, (shape, qty, rot) in enumerate(job["items"])]
        inst = spyrrow.StripPackingInstance("flatweave", job["width"], items)
        cfg = spyrrow.StripPackingConfig(early_termination=job["early"], total_computation_time=job["seconds"],
                                         num_workers=job["workers"], seed=job["seed"],
                                         min_items_separation=job["gap"] or None)
        feasible = [spyrrow.ReportType.ExplFeas, spyrrow.ReportType.CmprFeas, spyrrow.ReportType.Final]
        progress = spyrrow.ProgressQueue()
        done: dict = {}

        def run():
            try:
                done["solution"] = inst.solve(cfg, progress=progress)
            except BaseException as exc:  # said to the parent in one line below
                done["error"] = exc

        thread = threading.Thread(target=run, daemon=True)
        thread.start()
        best = math.inf

        def send(kind, solution):
            out.put((kind, float(solution.width), [(int(p.id), float(p.rotation), float(p.translation[0]),
                                                    float(p.translation[1])) for p in solution.placed_items]))

        while thread.is_alive():
            thread.join(POLL)
            for kind, solution in progress.drain():
                if any(kind == f for f in feasible) and solution.width < best:  # (report types do not hash)
                    best = solution.width
                    send("progress", solution)
        if "error" in done:
            out.put(("error", f"{type(done['error']).__name__}: {done['error']}", []))
            return
        send("final", done["solution"])
    except BaseException as exc:  # an import or a bad instance: one line for the parent
        out.put(("error", f"{type(exc).__name__}: {exc}", []))


def _engine_items(items) -> list[tuple[int, bool]]:
    """The engine's items: (our item's index, mirrored) each; an item in mirror pairs is two, as drawn
    and mirrored, the quantity split between them."""
    out = []
    for k, it in enumerate(items):
        out.append((k, False))
        if it.mirror and it.quantity > 1:
            out.append((k, True))
    return out


def _engine_job_item(it: NestItem, mirrored: bool, grow: float) -> tuple:
    """(shape, quantity, rotations) of ``it`` (its mirror image: x negated, the grain with it) for the engine."""
    if not mirrored:
        return _engine_shape(it.outline, it.grain_deg, grow), it.drawn, None if it.turns is None else list(it.turns)
    flipped = it.outline * np.array([-1.0, 1.0])
    return (_engine_shape(flipped, 180.0 - it.grain_deg, grow), it.quantity - it.drawn,
            None if it.turns is None else list(it.turns))


def _marker(items, placed, width: float, gap: float, length: float, t0: float, stopped: bool, reports: int):
    """A Marker from the engine's placements (engine item index, rotation, x, y), in each item's own frame."""
    engine = _engine_items(items)
    copies: dict = {}
    out = []
    for e, rot, x, y in placed:
        k, mirrored = engine[e]
        it = items[k]
        copy = copies.get((k, mirrored), 0)
        copies[(k, mirrored)] = copy + 1
        # the engine placed the outline (reflected first if mirrored) turned so its grain runs along the
        # roll: one rotation about the origin in all; a mirrored copy's grain is at 180 - grain
        grain = 180.0 - it.grain_deg if mirrored else it.grain_deg
        out.append(Placement(k, copy + (it.drawn if mirrored else 0), float((rot - grain + 180.0) % 360.0 - 180.0),
                             x, y, mirrored))
    return Marker(tuple(items), tuple(out), float(width), float(length), float(gap), time.perf_counter() - t0,
                  stopped, reports)


def nest(items, roll_width: float, gap: float = 0.0, seconds: float = DEFAULT_SECONDS, seed: int = 0,
         workers: int | None = None, on_progress=None, stop=None, early: bool = True) -> Marker:
    """The marker of ``items`` (:class:`NestItem` s) on a roll ``roll_width`` mm wide with ``gap`` mm
    between pieces, in ``seconds`` at most (sparrow's budget, in whole seconds).

    ``on_progress(marker)`` is called (in this thread) with each better marker as it is found; ``stop``
    (a ``threading.Event``), once set, ends the solve at once with the best marker so far
    (``Marker.stopped``). ``workers``: the engine's threads (None: every core). ``early``: the engine
    may end before its time when it sees no more to gain. One-line SettingsError: a bad width, gap or
    time, a piece wider than the roll in every rotation it may take, no marker found in the time given.
    """
    items = tuple(items)
    _check(items, roll_width, gap, seconds)
    grow = outline_margin(roll_width)
    job = {"items": [_engine_job_item(items[k], mirrored, grow) for k, mirrored in _engine_items(items)],
           "width": float(roll_width), "gap": float(gap), "seconds": max(1, int(math.ceil(seconds))),
           "workers": workers if workers is not None else (os.cpu_count() or 1), "seed": int(seed),
           "early": bool(early)}
    ctx = pool_context()
    out = ctx.Queue()
    child = ctx.Process(target=_child, args=(job, out), name="flatweave-nest", daemon=True)
    t0 = time.perf_counter()
    child.start()
    best, reports, final, error = None, 0, None, None
    try:
        while True:
            if stop is not None and stop.is_set():
                break
            try:
                kind, length, placed = out.get(timeout=POLL)
            except queue_module.Empty:
                if not child.is_alive() and out.empty():
                    error = error or f"the nesting process ended without an answer (exit code {child.exitcode})"
                    break
                continue
            if kind == "error":
                error = length
                break
            reports += 1
            marker = _marker(items, placed, roll_width, gap, length, t0, False, reports)
            if kind == "final":
                final = marker
                break
            if best is None or marker.length < best.length:
                best = marker
                if on_progress is not None:
                    on_progress(best)
    finally:
        if child.is_alive():
            child.terminate()
        child.join(5.0)
        out.close()
    if final is not None:
        # the engine's final answer, unless a report it made before was shorter (it keeps its best)
        return final if best is None or final.length <= best.length else best
    if best is not None:
        return Marker(best.items, best.placements, best.roll_width, best.length, best.gap,
                      time.perf_counter() - t0, True, reports)
    if error is not None:
        raise FlatweaveError(f"nesting failed: {error}")
    raise SettingsError(f"no marker was found in {time.perf_counter() - t0:.1f} s: give it more time")


def marker_problems(marker: Marker, tol: float = 1e-6) -> list[str]:
    """What is wrong with a marker, one line each (empty when all is well): a copy missing or placed
    twice, a mirror pair's copy not mirrored as its pair asks, a piece off the roll (beyond y 0 to the
    width or x below 0, or past the length), two pieces overlapping or nearer than the gap (less ``tol`` mm)."""
    from shapely import STRtree
    from shapely.geometry import Polygon

    problems = []
    want = {(k, c) for k, it in enumerate(marker.items) for c in range(it.quantity)}
    have = [(p.item, p.copy) for p in marker.placements]
    if sorted(have) != sorted(want):
        problems.append(f"{len(have)} copies placed, {len(want)} asked for")
    for p in marker.placements:
        if p.mirrored != marker.items[p.item].copy_mirrored(p.copy):
            problems.append(f"{marker.items[p.item].name} copy {p.copy + 1} is "
                            f"{'mirrored' if p.mirrored else 'not mirrored'}, its pair asks otherwise")
    polys = [Polygon(o) for o in marker.outlines()]
    for p, poly in zip(marker.placements, polys):
        x0, y0, x1, y1 = poly.bounds
        if y0 < -tol or y1 > marker.roll_width + tol or x0 < -tol or x1 > marker.length + tol:
            problems.append(f"{marker.items[p.item].name} copy {p.copy + 1} lies off the roll")
    tree = STRtree(polys)
    reach = max(marker.gap - tol, 0.0)
    for i, j in zip(*tree.query(polys, predicate="dwithin", distance=reach)) if reach > 0 else zip(
            *tree.query(polys, predicate="intersects")):
        if i < j and (reach > 0 or polys[i].intersection(polys[j]).area > tol * tol):
            a, b = marker.placements[i], marker.placements[j]
            problems.append(f"{marker.items[a.item].name} copy {a.copy + 1} and {marker.items[b.item].name} "
                            f"copy {b.copy + 1} {'overlap' if reach == 0 else 'are nearer than the gap'}")
    return problems
