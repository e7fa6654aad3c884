"""Seams kept in a project: the seam lines drawn on a piece and the panels they split it into (issue 42).

A :class:`Sewing` is one shape split into panels: the surface and region it
covers (the piece that was split), its seam lines (:class:`SeamLine`: a (u, v)
polyline and the seam's own settings: seam allowance, notches placed by the
user, the matched-length option) and, per panel of the split
(:func:`flatweave.geometry.panels.split_region`, in its order), the name of the
project's piece that panel is. Each panel is a piece like any other (its own
settings, grain, darts, result); its region is the split's, and a seam edit
re-splits the shape: a panel whose region did not change keeps its piece as it
was (its result still current), one whose region changed keeps its settings
with the new region (its result goes stale, a solve answers it), a panel the
edit made is a new piece with its neighbour's settings, one it removed goes.

The functions here are edits: each returns a new project (one undoable step in a
:class:`flatweave.document.history.Document`); a refused edit is a one-line
SettingsError and nothing changes. :func:`flatweave.document.checks.seam_rows` reads
the sew lines' two sides off the panels' results.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from flatweave.document.pieces import free_name, index_of, pieces_of, set_rosettes, with_pieces
from flatweave.errors import SettingsError
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.geometry.panels import Seam, seam_from_spec, split_region
from flatweave.geometry.region import Region, cover_for
from flatweave.export.sheet import build_sheet, mm_per_unit
from flatweave.geometry.numerics import polyline_distance
from flatweave.method.seams import MATCH_MM, MATCH_PCT, SewMatch, flat_notches, flat_sew_line, notches_along

__all__ = ["SeamLine", "Sewing", "SeamRow", "MAX_SEAMS", "MAX_ALLOWANCE_MM", "sewing_of", "sew", "set_seams",
           "sewing_index", "add_seam", "replace_seam", "remove_seam", "edit_seam", "split_of", "panel_names",
           "sew_marks", "piece_sheet", "seam_line_from_spec"]

MAX_SEAMS = 200  # seams of one shape: a garment has 5 to 40
MAX_ALLOWANCE_MM = 100.0  # a seam allowance beyond 10 cm is a typing slip
MAX_NOTCHES = 1000  # notches the user places on one seam
NOTCH_SLACK = 0.01  # a seam file's notch may lie this far off its seam (a fraction of the domain's diagonal)


@dataclass(frozen=True, eq=False)
class SeamLine:
    """One seam of a shape, as the user drew it.

    name : shown in the Seams list and on the sew lines (distinct in its sewing)
    uv : (k, 2) its (u, v) polyline on the surface
    closed : it runs round a loop (its last point joined to its first)
    allowance_mm : the seam allowance of both panels along it in the cut files (None: the export's)
    notches : (u, v) points on it where both panels get a notch, besides its ends and every N mm
    matched : the two sides are to come out equal in length (a constraint across the seam)
    """

    name: str
    uv: np.ndarray
    closed: bool = False
    allowance_mm: float | None = None
    notches: tuple = ()
    matched: bool = False

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name.strip() or len(self.name) > 200 or "\n" in self.name:
            raise SettingsError(f"a seam's name must be a line of 1 to 200 characters, got {self.name!r:.60}")
        uv = np.asarray(self.uv, dtype=float)
        if uv.ndim != 2 or uv.shape[1] != 2 or len(uv) < 2 or not np.isfinite(uv).all():
            raise SettingsError(f"seam {self.name!r}: its points must be at least two finite (u, v) pairs")
        uv = uv.copy()
        uv.flags.writeable = False
        object.__setattr__(self, "uv", uv)
        if not isinstance(self.closed, bool) or not isinstance(self.matched, bool):
            raise SettingsError(f"seam {self.name!r}: closed and matched are true or false")
        a = self.allowance_mm
        if a is not None and (isinstance(a, bool) or not isinstance(a, (int, float)) or not math.isfinite(a)
                              or not 0 <= a <= MAX_ALLOWANCE_MM):
            raise SettingsError(f"seam {self.name!r}: its seam allowance must be 0 to {MAX_ALLOWANCE_MM:g} mm "
                                f"(or the export's), got {a!r:.40}")
        notches = np.asarray(self.notches, dtype=float).reshape(-1, 2) if len(self.notches) else np.zeros((0, 2))
        if len(notches) > MAX_NOTCHES or not np.isfinite(notches).all():
            raise SettingsError(f"seam {self.name!r}: its notches must be at most {MAX_NOTCHES} finite (u, v) points")
        object.__setattr__(self, "notches", tuple(map(tuple, notches.tolist())))

    @property
    def seam(self) -> Seam:
        """The geometry's seam (:class:`flatweave.geometry.panels.Seam`)."""
        return Seam(self.name, np.asarray(self.uv), self.closed)

    def same_line(self, other: "SeamLine") -> bool:
        """Both run along the same points (their names and options aside): the split is the same."""
        return self.closed == other.closed and np.array_equal(self.uv, other.uv)

    def to_dict(self) -> dict:
        """The seam in the project file."""
        return {"name": self.name, "uv": np.asarray(self.uv).tolist(), "closed": self.closed,
                **({"allowance_mm": float(self.allowance_mm)} if self.allowance_mm is not None else {}),
                **({"notches": [list(p) for p in self.notches]} if self.notches else {}),
                **({"matched": True} if self.matched else {})}

    @classmethod
    def from_dict(cls, d: Any, what: str = "seam") -> "SeamLine":
        """The inverse of :meth:`to_dict`; a one-line SettingsError naming ``what``."""
        if not isinstance(d, dict) or "name" not in d or "uv" not in d:
            raise SettingsError(f"{what} must be an object with a name and uv points")
        try:
            uv = np.asarray(d["uv"], dtype=float)
            notches = np.asarray(d.get("notches", []), dtype=float)
        except (TypeError, ValueError):
            raise SettingsError(f"{what}: its uv and notches must be lists of [u, v] numbers") from None
        if notches.size and (notches.ndim != 2 or notches.shape[1] != 2):
            raise SettingsError(f"{what}: its notches must be a list of [u, v] numbers")
        try:
            return cls(d["name"], uv, d.get("closed", False), d.get("allowance_mm"), tuple(map(tuple, notches)),
                       d.get("matched", False))
        except SettingsError as exc:
            raise SettingsError(f"{what}: {exc}") from None


def seam_line_from_spec(surface: NurbsSurface, spec: Any, name: str) -> SeamLine:
    """A seam from its file's form (:func:`flatweave.geometry.panels.seam_from_spec`: drawn points and a
    view direction, or (u, v) points; ``name``, ``closed``) with its options: ``"allowance_mm"`` (its
    seam allowance), ``"notches"`` ([[u, v], ...] on it) and ``"matched"``; one line naming the problem."""
    seam = seam_from_spec(surface, spec, name)
    unknown = sorted(set(spec) - {"name", "closed", "uv", "points", "view_direction", "allowance_mm", "notches",
                                  "matched", "tolerance"})
    if unknown:
        raise SettingsError(f"seam {seam.name!r}: unknown key {unknown[0]!r} (a seam takes points and "
                            f"view_direction or uv, name, closed, allowance_mm, notches, matched)")
    notches = spec.get("notches", [])
    try:
        notches = np.asarray(notches, dtype=float)
    except (TypeError, ValueError):
        notches = np.zeros((1, 3))
    if notches.size and (notches.ndim != 2 or notches.shape[1] != 2):
        raise SettingsError(f'seam {seam.name!r}: "notches" must be a list of [u, v] points on it')
    if notches.size and np.isfinite(notches).all():
        # a notch is put on the seam at its nearest point: one farther off than a drawing slip is a mistake
        size = float(np.linalg.norm(np.diff(np.asarray(surface.domain, dtype=float), axis=1)))
        line = np.vstack([seam.uv, seam.uv[:1]]) if seam.closed else seam.uv
        off = polyline_distance(notches, line)
        if off.max() > NOTCH_SLACK * size:
            k = int(np.argmax(off))
            raise SettingsError(f"seam {seam.name!r}: notch {k + 1} ({notches[k, 0]:.4g}, {notches[k, 1]:.4g}) lies "
                                f"off the seam ({off[k]:.3g} in (u, v)); give points on it")
    return SeamLine(seam.name, seam.uv, seam.closed, spec.get("allowance_mm"), tuple(map(tuple, notches)),
                    spec.get("matched", False))


@dataclass(frozen=True, eq=False)
class Sewing:
    """One shape split by seams into panels.

    name : the shape's (the piece that was split: its name when it was)
    surface, source : the surface it lies on and where that came from (one of the project's sources)
    region : the region the seams split (None: the surface's whole domain)
    seams : its :class:`SeamLine` s, in the order drawn
    panels : per panel of the split, in its order, the name of the piece it is
    """

    name: str
    surface: NurbsSurface
    source: str | None
    region: Region | None
    seams: tuple
    panels: tuple

    def __post_init__(self):
        object.__setattr__(self, "seams", tuple(self.seams))
        object.__setattr__(self, "panels", tuple(self.panels))
        if not 1 <= len(self.panels) or len(self.seams) > MAX_SEAMS:
            raise SettingsError(f"sewing {self.name!r}: 1 or more panels and at most {MAX_SEAMS} seams")
        keys = [s.name.strip().casefold() for s in self.seams]
        if len(set(keys)) != len(keys):
            raise SettingsError(f"sewing {self.name!r}: two seams have the same name")

    def seam_index(self, k: Any) -> int:
        """A seam's index from an index or its name; one line when there is none."""
        if isinstance(k, str):
            for i, s in enumerate(self.seams):
                if s.name == k:
                    return i
            raise SettingsError(f"no seam is named {k!r} in {self.name!r}")
        if isinstance(k, bool) or not isinstance(k, int) or not 0 <= k < len(self.seams):
            raise SettingsError(f"no seam {k!r}: {self.name!r} has {len(self.seams)}")
        return k

    def to_dict(self, source: int) -> dict:
        """The sewing in the project file; ``source`` the index of its surface in the file's sources."""
        return {"name": self.name, "source": source,
                "region": None if self.region is None else self.region.to_dict(),
                "seams": [s.to_dict() for s in self.seams], "panels": list(self.panels)}


@dataclass(frozen=True)
class SeamRow:
    """One sew line of a project, as the Seams list shows it: its ``name``, its seam's, the
    sewing's, the two ``panels`` (piece names; one where a seam only opens a piece), their flat
    ``lengths`` (model units; None for a side not solved, or solved before its last change);
    ``matched``: its seam asks for equal sides, and, when its panels were solved matched, the cost:
    ``energy_cost`` how much higher their energy EN is than solved alone (EN's units; None otherwise)
    and ``energy_cost_pct`` the same in percent of that (large when the panels lie near rest alone)."""

    name: str
    seam: str
    sewing: str
    panels: tuple
    lengths: tuple
    matched: bool = False
    energy_cost_pct: float | None = None
    energy_cost: float | None = None

    @property
    def solved(self) -> bool:
        return len(self.lengths) == 2 and None not in self.lengths

    @property
    def difference(self) -> float | None:
        return abs(self.lengths[0] - self.lengths[1]) if self.solved else None

    @property
    def difference_pct(self) -> float | None:
        if not self.solved:
            return None
        return SewMatch(self.name, self.seam, self.panels, self.lengths).difference_pct

    def over(self, mm_per_unit: float) -> bool:
        """The sides differ by more than the tolerance (MATCH_PCT percent and MATCH_MM mm)."""
        return self.solved and self.difference_pct > MATCH_PCT and self.difference * mm_per_unit > MATCH_MM

    def to_dict(self) -> dict:
        """The result file's form (issue 42): name, seam, panels, lengths, difference, difference_pct."""
        return {"name": self.name, "seam": self.seam, "panels": list(self.panels), "lengths": list(self.lengths),
                "difference": self.difference, "difference_pct": self.difference_pct, "matched": self.matched,
                **({"energy_cost": self.energy_cost, "energy_cost_pct": self.energy_cost_pct}
                   if self.energy_cost is not None else {})}


_SPLITS: dict[int, Any] = {}
"""split_of's answer for live sewings, by id (sewings are immutable)."""


def split_of(sewing: Sewing):
    """The sewing's :class:`flatweave.geometry.panels.Split` (its panels in the order of ``sewing.panels``)."""
    out = _SPLITS.get(id(sewing))
    if out is None:
        out = _SPLITS[id(sewing)] = split_region(sewing.surface, sewing.region, [s.seam for s in sewing.seams], None)
        weakref.finalize(sewing, _SPLITS.pop, id(sewing), None)
    return out


def sewing_of(project, piece) -> Sewing | None:
    """The sewing piece ``piece`` (an index or a name) is a panel of, or None."""
    name = pieces_of(project)[index_of(project, piece)].name
    return next((s for s in project.sewings if name in s.panels), None)


def sewing_index(project, sewing: Any) -> int:
    """The index in ``project.sewings`` of ``sewing`` (a Sewing of it or its name); one line when none."""
    if isinstance(sewing, Sewing):
        for i, s in enumerate(project.sewings):
            if s is sewing:
                return i
        raise SettingsError(f"sewing {sewing.name!r} is not this project's")
    for i, s in enumerate(project.sewings):
        if s.name == sewing:
            return i
    raise SettingsError(f"no seams are drawn on {sewing!r}")


def _overlap(a: Region | None, b: Region | None, surface) -> float:
    """The (u, v) area two regions share."""
    return float(cover_for(surface, a).polygon.intersection(cover_for(surface, b).polygon).area)


SEED_EDGE = 0.02
"""A panel keeps its seed through a re-split while it lies this far inside its new region's outline
(a fraction of the domain); nearer a seam, the drape would leave the panel at once: its middle instead."""


def _panel_settings(settings, region: Region, surface, keep_seed: bool = True):
    """``settings`` on ``region``: its seed kept when asked and well inside it (else the region's middle),
    its curve darts kept when they lie in it, its yarn constraints (lattice rows of the old drape) dropped."""
    cover = cover_for(surface, region)
    at = cover.seed_uv(settings.seed)
    inside = keep_seed and cover.contains(at).all() and float(cover.edge_distance(at)[0]) >= SEED_EDGE
    seed = settings.seed if inside else cover.default_seed
    darts = tuple(d for d in settings.darts if d.kind != "curve" or cover.contains(np.asarray(d.uv)).all())
    yarns = settings.yarns if region == settings.region else ()
    return replace(settings, region=region, seed=seed, darts=darts, yarns=yarns)


def _resplit(project, i: int, seams, spacing: float | None = None, fresh: bool = False):
    """``project`` with sewing ``i`` split anew by ``seams`` (see the module docstring); ``fresh``:
    every panel a new piece (the first split of a piece, which the panels replace)."""
    old = project.sewings[i]
    pieces = list(pieces_of(project))
    by_name = {p.name: k for k, p in enumerate(pieces)}
    mine = [by_name[n] for n in old.panels if n in by_name]
    if spacing is None:
        spacing = min(pieces[k].settings.spacing for k in mine)
    split = split_region(old.surface, old.region, [s.seam for s in seams], spacing)
    # each new panel is the old one it shares the most area with (one each, the largest overlaps first)
    pairs = sorted(((_overlap(p.region, pieces[k].settings.region, old.surface), j, k)
                    for j, p in enumerate(split.panels) for k in mine), reverse=True)
    taken, made = {}, set()
    for area, j, k in ([] if fresh else pairs):
        if area > 0 and j not in taken and k not in made:
            taken[j] = k
            made.add(k)
    names, new_pieces = [], {}
    for j, panel in enumerate(split.panels):
        if j in taken:
            piece = pieces[taken[j]]
            if piece.settings.region != panel.region:
                piece = replace(piece, settings=_panel_settings(piece.settings, panel.region, old.surface))
            new_pieces[taken[j]] = piece
            names.append(piece.name)
        else:  # a panel the edit made: its neighbour's settings, its darts and result not
            near = max(mine, key=lambda k: _overlap(panel.region, pieces[k].settings.region, old.surface)
                       if pieces[k].settings.region is not None else 0.0)
            base = pieces[near]
            name = free_name([p.name for k, p in enumerate(pieces) if not (fresh and k in mine)] + names, "panel",
                             numbered=True)
            settings = _panel_settings(replace(base.settings, darts=()), panel.region, old.surface, keep_seed=False)
            piece = replace(base, name=name, settings=settings, result=None, region_name="", candidates=())
            new_pieces[("new", j)] = piece
            names.append(name)
    # the pieces in order: those kept where they were, new panels after the sewing's last, removed ones gone
    active = pieces[project.piece_index]
    out, last = [], max(mine)
    for k, p in enumerate(pieces):
        if k in mine:
            if k in new_pieces:
                out.append(new_pieces[k])
        else:
            out.append(p)
        if k == last:
            out.extend(v for key, v in new_pieces.items() if isinstance(key, tuple))
    sewing = replace(old, seams=tuple(seams), panels=tuple(names))
    _SPLITS[id(sewing)] = split
    weakref.finalize(sewing, _SPLITS.pop, id(sewing), None)
    sewings = project.sewings[:i] + (sewing,) + project.sewings[i + 1:]
    names_now = [p.name for p in out]
    at = names_now.index(active.name) if active.name in names_now else names_now.index(names[0])
    result = _ease_kept(with_pieces(project, out, at, sewings), sewing)
    return set_rosettes(result, result.rosettes) if result.rosettes else result


def _ease_kept(project, sewing: Sewing):
    """``project`` with its panels of ``sewing`` easing only the sew lines of its matched seams as they are
    (:mod:`flatweave.document.matching`): an ease along a seam moved, deleted or no longer matched goes
    (the panel's result then stale: a solve answers it)."""
    split = split_of(sewing)
    matched = {s.name for s in sewing.seams if s.matched}
    lines = {tuple(map(tuple, np.asarray(line.uv).tolist())) for line in split.sews if line.seam in matched}
    mine = set(sewing.panels)
    pieces = list(pieces_of(project))
    changed = False
    for k, p in enumerate(pieces):
        if p.name in mine and p.settings.ease:
            ease = tuple(e for e in p.settings.ease if e[0] in lines)
            if ease != p.settings.ease:
                pieces[k] = replace(p, settings=replace(p.settings, ease=ease))
                changed = True
    return with_pieces(project, pieces, project.piece_index) if changed else project


def sew(project, piece, seams) -> Any:
    """``project`` with piece ``piece`` (an index or a name; not already a panel) split by ``seams``
    (:class:`SeamLine` s) into panels, which take its place: each a piece with its settings (a seed in
    its own region, the curve darts that lie in it), named "panel N" in the split's order; the shape
    (the :class:`Sewing`) keeps the piece's name."""
    k = index_of(project, piece)
    p = pieces_of(project)[k]
    if sewing_of(project, k) is not None:
        raise SettingsError(f"{p.name!r} is a panel already: add the seam to its shape's seams")
    name = free_name([s.name for s in project.sewings], p.name)
    sewing = Sewing(name, p.surface, p.source, p.settings.region, (), (p.name,))
    project = replace(project, sewings=project.sewings + (sewing,))
    return _resplit(project, len(project.sewings) - 1, tuple(seams), p.settings.spacing, fresh=True)


def set_seams(project, sewing, seams):
    """``project`` with the seams of ``sewing`` (a Sewing or its name) ``seams``: re-split when the
    lines changed, their names and options only otherwise (the panels untouched)."""
    i = sewing_index(project, sewing)
    old = project.sewings[i]
    seams = tuple(seams)
    if len(seams) == len(old.seams) and all(a.same_line(b) for a, b in zip(seams, old.seams)):
        new = replace(old, seams=seams)
        if all(a.name == b.name for a, b in zip(seams, old.seams)):  # the same split; renamed: its sew lines too
            _SPLITS[id(new)] = split_of(old)
            weakref.finalize(new, _SPLITS.pop, id(new), None)
        return _ease_kept(replace(project, sewings=project.sewings[:i] + (new,) + project.sewings[i + 1:]), new)
    return _resplit(project, i, seams)


def add_seam(project, seam: SeamLine, piece=None):
    """``project`` with ``seam`` added to the shape piece ``piece`` (default the active one) is a panel
    of, or splitting that piece when it is not one; a name already taken gets a number."""
    k = project.piece_index if piece is None else index_of(project, piece)
    sewing = sewing_of(project, k)
    taken = [] if sewing is None else [s.name for s in sewing.seams]
    seam = replace(seam, name=free_name(taken, seam.name))
    if sewing is None:
        return sew(project, k, (seam,))
    return set_seams(project, sewing, sewing.seams + (seam,))


def replace_seam(project, sewing, k, seam: SeamLine):
    """``project`` with seam ``k`` (an index or a name) of ``sewing`` replaced by ``seam``."""
    s = project.sewings[sewing_index(project, sewing)]
    i = s.seam_index(k)
    return set_seams(project, s, s.seams[:i] + (seam,) + s.seams[i + 1:])


def remove_seam(project, sewing, k):
    """``project`` without seam ``k`` of ``sewing``: the panels either side of it joined."""
    s = project.sewings[sewing_index(project, sewing)]
    i = s.seam_index(k)
    return set_seams(project, s, s.seams[:i] + s.seams[i + 1:])


def edit_seam(project, sewing, k, **changes):
    """``project`` with seam ``k`` of ``sewing`` changed (name, allowance_mm, notches, matched, uv, closed)."""
    s = project.sewings[sewing_index(project, sewing)]
    i = s.seam_index(k)
    return set_seams(project, s, s.seams[:i] + (replace(s.seams[i], **changes),) + s.seams[i + 1:])


def panel_names(sewing: Sewing) -> dict:
    """The split's panel names ("panel 1", ...) -> the names of the pieces they are."""
    return {p.name: name for p, name in zip(split_of(sewing).panels, sewing.panels)}


def sew_marks(project, piece, every: float = 0.0) -> tuple[list, list]:
    """What the cut file of piece ``piece`` (an index or a name; solved) carries of its seams when it
    is a panel: (notches, allowances) for :func:`flatweave.export.sheet.build_sheet`. Notches at each
    of its sew lines' ends, every ``every`` model units of the seam's 3D length from its first point
    (0: none between) and at the seam's user-placed notches, each (point, sew line direction) on the
    piece's pattern, where the other panel's fall at the same points of the seam; allowances: its sew
    lines along a seam with its own allowance, as (flat stretch, mm). ([], []) for a piece not a panel."""
    p = pieces_of(project)[index_of(project, piece)]
    sewing = sewing_of(project, p.name)
    if sewing is None or p.result is None:
        return [], []
    split = split_of(sewing)
    me = next(q.name for q, name in zip(split.panels, sewing.panels) if name == p.name)
    seams = {s.name: s for s in sewing.seams}
    notches, allowances = [], []
    for line in split.sews:
        if me not in line.panels:
            continue
        seam = seams[line.seam]
        at = notches_along(sewing.surface, line.uv, every)
        if seam.notches:  # the user's, on the stretch of the seam nearest each
            mine = [q for q in seam.notches if _stretch_of(split, seam.name, q) == line.name]
            at = np.vstack([at, np.asarray(mine, dtype=float).reshape(-1, 2)])
        xy, _, along = flat_notches(p.result, line.uv, at, with_tangents=True)
        notches += [(q, t) for q, t in zip(xy, along) if np.isfinite(q).all() and np.isfinite(t).all()]
        if seam.allowance_mm is not None:
            flat = flat_sew_line(p.result, line.uv)
            if len(flat) >= 2:
                allowances.append((flat, float(seam.allowance_mm)))
    return notches, allowances


def _stretch_of(split, seam: str, uv) -> str:
    """The name of the stretch of ``seam`` nearest the (u, v) point ``uv``."""
    lines = [line for line in split.sews if line.seam == seam]
    d = [float(polyline_distance(np.asarray(uv, dtype=float)[None], line.uv)[0]) for line in lines]
    return lines[int(np.argmin(d))].name


def piece_sheet(project, piece, seam_allowance_mm: float, every_mm: float = 0.0, name: str | None = None):
    """The :class:`flatweave.export.sheet.Sheet` of piece ``piece`` (solved) as its cut files and the ply
    book draw it: its quantity, and, a panel, its seams' notches (every ``every_mm`` mm along them too)
    and their own seam allowances (:func:`sew_marks`); labelled ``name`` (default the piece's)."""
    p = pieces_of(project)[index_of(project, piece)]
    notches, allowances = sew_marks(project, p.name, every_mm / mm_per_unit(project.units) if every_mm else 0.0)
    return build_sheet(p.result, project.units, seam_allowance_mm, name or p.name, p.quantity,
                       sew_notches=tuple(notches),
                       allowances=tuple(allowances))
