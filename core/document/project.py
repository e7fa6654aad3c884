"""The project: the document a designer edits and saves, and its file.

A :class:`Project` is an immutable snapshot of everything a flattening job
holds: the surface, the settings (including darts and yarn constraints), the
display choices that belong to the job (model units, shear warning and limit
angles) and the last result. Every edit makes a new Project
(:meth:`Project.with_settings` and friends), so an undo history is a list of
them (:mod:`flatweave.document.history`) and an autosave writes one without locking.

The file (``.flatweave``) is JSON::

    {"format": "flatweave-project", "version": 7, "flatweave": "0.1.0",
     "name": "octant",
     "sources": [
       {"source": "resources/surfaces/octant.json" (where it came from: a file, "FILE#face=3", or null),
        "surface": {geomdl JSON document},
        "surface_fit": optional, a mesh fit's record (flatweave.geometry.meshfit.MeshFit)},
       ...],
     "display": {"units": "m", "shear_warning_deg": 15.0, "shear_limit_deg": 30.0},
     "pieces": [
       {"name": "octant", "source": the index of its surface in "sources",
        "quantity": 1, "sequence": null (or its place in a laminate, 1 first),
        "settings": {spacing, spacing_warp, material, seed, angle_deg, paths,
                     solver, tol, max_iter, max_seconds, max_nodes,
                     region: null (the whole domain) or {"loops": [[[u, v], ...], ...]
                             (outer loop first, then the holes), "corners": per loop
                             [point indices] or null} (flatweave.geometry.region.Region)},
        "darts": [{"kind": "plane", "name", "visible", "plane": [a, b, c, d], "box": [6] or null}
                  or {"kind": "curve", "name", "visible", "uv": [[u, v], ...],
                      "handles": [[u, v], ...] (optional), "view_dir": [dx, dy, dz] (optional)}],
        "yarns": [{"kind": "weft" or "warp", "index", "plane": [a, b, c, d], "k",
                   "point": [x, y, z] (optional: the picked point; index is then as resolved)}],
        "result": a result document (flatweave.method.pipeline.result_to_dict, its
                  "warnings" included) with "history": [EN after each iteration, ...], or null,
        "candidates": optional, the regions kept beside the active one (flatweave.document.candidates)},
       ...],
     "current": the index of the active piece in "pieces",
     "materials": optional, the materials table (flatweave.method.materials.Fabric.to_dict each),
     "rosettes": optional, the tool's rosettes [{"name", "origin": [x, y, z], "zero": [dx, dy, dz]}]
                 (flatweave.document.rosettes); a piece oriented from one has "rosette" (its name) and
                 "orientation" (degrees) beside its "quantity",
     "sewings": optional, the shapes split by seams into panels (flatweave.document.sewing):
                [{"name", "source": the index of its surface, "region": as settings.region,
                  "seams": [{"name", "uv": [[u, v], ...], "closed", "allowance_mm" (optional, mm),
                             "notches": [[u, v], ...] (optional), "matched": true (optional)}],
                  "panels": per panel of the split, in its order, its piece's name (null: deleted)}],
     "cut_plan": optional, how its markers are nested (flatweave.document.cutsettings): {"roll_widths":
                 [{"material", "mm"}], "gap_mm", "seconds", "allowance_mm", "overlap_mm", "rotations" (null:
                 each material's), "splices": [{"piece": the item's name, "mm": [...]}], "mirror": [piece names]}}

Versions. Version 2 added the result's ``history`` (the energy trace, so the
energy plot comes back with the project). Version 3 added the result's
``warnings`` and ``metrics.uncovered_pct`` and a yarn's ``point``; an older
result gets its warnings made from its saved metrics when read (its coverage
measured on the rebuilt mesh, which is the saved one), an older yarn is an
explicit index. Version 4 added ``settings.region`` (the piece's region of
the surface's domain: a trimmed CAD face, or a region given in (u, v)); an
older file's is null, the whole domain. Version 5 holds a list of pieces
(:mod:`flatweave.document.pieces`); an older file's settings, darts, yarns,
result and candidates are its one piece, named after the project. Version 6
holds a list of sources (the surfaces its pieces lie on: faces of one CAD
file, other files); an older file's surface is its only source. Version 7
added ``sewings`` (seams splitting a piece into panels); an older file has
none. Version 8 added ``cut_plan`` (the nesting's settings, splices placed by
hand and mirror pairs); an older file nests as made. A dart's ``visible``, ``handles``
and ``view_dir`` came during version 1 and are optional (a dart without them
is visible and has no drawn points). Older files are read by upgrading their
document one version at a time (:data:`UPGRADES`) before it is read as the
current version; ``tests/data/projects`` keeps frozen files of every older
version, which must keep opening. A file from a newer version is refused
with a message saying so.

Floats are written with ``repr`` precision, so a project reads back
bit-identical. The result is restored from its nodes' lattice positions and
(u, v) (the mesh, xyz and pattern are recomputed by the same code that made
them, so they come back identical) and its stored metrics. Saves are atomic
(:func:`flatweave.files.write_json`). Every problem reading a file is a one-line
:class:`ProjectError` naming the file: not JSON, not a project, a version
newer than this program reads, a damaged entry.
"""

from __future__ import annotations

import json
import math
import os
import weakref
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from flatweave.version import __version__
from flatweave.method.darts import CUT_DART_KEYS, dart_from_dict
from flatweave.method.energy import YarnConstraint
from flatweave.errors import FlatweaveError, SettingsError
from flatweave.files import check_json_depth, decode_array, read_input, write_json
from flatweave.method.lattice import MATERIALS, Material
from flatweave.method.materials import FABRICS, Fabric, check_table
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.method.settings import SETTINGS_KEYS as _SETTINGS_KEYS
from flatweave.method.result import FlattenResult, judged, result_state_dict
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import flatten_iter, state_from_dict
from flatweave.method.settings import ease_from_list, settings_to_dict, validate_settings
from flatweave.method.solvers import solver_entry
from flatweave.geometry.quadrature import region_area
from flatweave.method.solver import State
from flatweave.geometry.surface_json import surface_from_json_dict, surface_to_json_dict
from flatweave.geometry.region import Region
from flatweave.document.candidates import candidates_to_dict
from flatweave.geometry.meshfit import MeshFit, with_fit
from flatweave.geometry.region import cover_for
from flatweave.document.candidates import candidates_from_dict
from flatweave.document.pieces import (MAX_PIECES, Piece, check_piece, check_pieces, pieces_of, placed, sources_of,
                                      with_pieces)
from flatweave.document.rosettes import MAX_ROSETTES, ToolRosette, check_rosettes
from flatweave.document.sewing import SeamLine, Sewing, split_of
from flatweave.document.cutsettings import CutPlanSettings

__all__ = ["Project", "ProjectError", "UNITS", "PROJECT_FORMAT", "PROJECT_VERSION", "PROJECT_SUFFIX",
           "DRAPE_KEYS", "settings_from_dict", "settings_equal", "labels_equal",
           "needs_new_drape", "drops_a_dart", "warm_start", "project_to_dict", "project_from_dict", "save_project",
           "load_project", "result_from_dict", "project_problems", "new_project", "UPGRADES"]

PROJECT_FORMAT = "flatweave-project"
PROJECT_VERSION = 8
PROJECT_SUFFIX = ".flatweave"

UNITS = {"mm": 0.001, "cm": 0.01, "m": 1.0, "in": 0.0254}
"""Model units a user can choose, with their length in metres."""

DRAPE_KEYS = ("spacing", "spacing_warp", "seed", "angle_deg", "paths", "max_nodes", "region")
"""Settings that decide the drape: changing one needs a new drape, not a warm start."""


class ProjectError(FlatweaveError, ValueError):
    """A project file cannot be read, or a project value is invalid (one line)."""


# ---------------------------------------------------------------------- the model
@dataclass(frozen=True, eq=False)
class Project:
    """One flattening job, immutable.

    surface : the NURBS surface the active piece lies on (the other pieces carry their own:
        :func:`flatweave.document.pieces.sources_of` lists the distinct ones)
    settings : FlattenSettings (darts and yarn constraints included)
    name : a short name (the surface file's stem or the example's name)
    source : where the active piece's surface came from (a path), or None
    units : model units, a key of :data:`UNITS` (what one coordinate unit is)
    shear_warning_deg, shear_limit_deg : shear display thresholds, 0 < warning < limit <= 90
    result : the last FlattenResult, or None; it may be stale (made with other
        settings, see :attr:`result_is_current`)

    Equality is identity (arrays inside); compare :func:`project_to_dict` s.
    """

    surface: NurbsSurface
    settings: FlattenSettings
    name: str = "untitled"
    source: str | None = None
    units: str = "m"
    shear_warning_deg: float = 15.0
    shear_limit_deg: float = 30.0
    result: FlattenResult | None = None
    view: tuple = ()  # the window's view choices, ((key, value), ...): view state, not an edit
    # candidate boundaries (flatweave.document.candidates): the active region's name and the
    # regions kept beside it (labels)
    region_name: str = ""
    candidates: tuple = ()
    # the pieces (flatweave.document.pieces): the active one's name, quantity and sequence (its settings,
    # result and candidates are the fields above), the others in order, and where the active one sits
    piece_name: str = ""  # "" when made: the project's name
    quantity: int = 1
    sequence: int | None = None
    others: tuple = ()
    piece_index: int = 0
    # the materials table (flatweave.method.materials): () when made, the bundled presets and the pieces' own
    materials: tuple = ()
    # the tool's rosettes (flatweave.document.rosettes), and the active piece's: the rosette its orientation
    # is measured from and the orientation (both None: its weft angle alone)
    rosettes: tuple = ()
    piece_rosette: str | None = None
    orientation: float | None = None
    # the shapes split by seams into panels (flatweave.document.sewing): each names the pieces its panels are
    sewings: tuple = ()
    # how its markers are nested (flatweave.document.cutsettings): roll widths, gap, splices, mirror pairs
    cut_plan: CutPlanSettings = CutPlanSettings()

    def __post_init__(self):
        if not self.piece_name:  # a project made as one piece: the piece is named after it
            object.__setattr__(self, "piece_name", self.name if isinstance(self.name, str) and self.name.strip()
                               else "piece 1")
        check_piece(self.piece_name, self.quantity, self.sequence, self.piece_rosette, self.orientation)
        if isinstance(self.piece_index, bool) or not isinstance(self.piece_index, int) \
                or not 0 <= self.piece_index <= len(self.others):
            raise SettingsError(f"the active piece's position {self.piece_index!r:.20} is not among the "
                                f"{len(self.others) + 1} pieces")
        if self.others:
            # a piece made without a surface lies on the active one's (a project of one source)
            object.__setattr__(self, "others", placed(self.others, self.surface, self.source))
            check_pieces(pieces_of(self))
        if not self.materials:
            object.__setattr__(self, "materials", table_for(pieces_of(self)))
        elif not all(isinstance(f, Fabric) for f in self.materials):
            raise TypeError("a project's materials must be Fabrics")
        check_table(self.materials, "the materials table")
        object.__setattr__(self, "rosettes", tuple(self.rosettes))
        check_rosettes(self.rosettes, pieces_of(self))
        if not isinstance(self.sewings, tuple):
            object.__setattr__(self, "sewings", tuple(self.sewings))
        if self.sewings:
            check_sewings(self.sewings, pieces_of(self))
        if not isinstance(self.cut_plan, CutPlanSettings):
            raise TypeError(f"Project.cut_plan must be a CutPlanSettings, got {type(self.cut_plan).__name__}")
        if not isinstance(self.surface, NurbsSurface):
            raise TypeError(f"Project.surface must be a NurbsSurface, got {type(self.surface).__name__}")
        if self.units not in UNITS:
            raise SettingsError(f"units must be one of {', '.join(UNITS)}, got {self.units!r}")
        w, lim = self.shear_warning_deg, self.shear_limit_deg
        for label, value in (("shear warning angle", w), ("shear limit angle", lim)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and 0 < value <= 90):
                raise SettingsError(f"{label} must be between 0 and 90 degrees, got {value!r}")
        if not w < lim:
            raise SettingsError(f"the shear warning angle ({w:g}) must be below the limit angle ({lim:g})")
        validate_settings(self.settings, job=True)

    # -------------------------------------------------------------- edits
    def with_settings(self, **changes) -> "Project":
        """A copy with some FlattenSettings fields changed (validated)."""
        return replace(self, settings=replace(self.settings, **changes))

    def with_display(self, **changes) -> "Project":
        """A copy with units or shear angles changed."""
        allowed = {"units", "shear_warning_deg", "shear_limit_deg"}
        if not set(changes) <= allowed:
            raise TypeError(f"with_display takes {', '.join(sorted(allowed))}")
        return replace(self, **changes)

    def with_result(self, result: FlattenResult | None) -> "Project":
        return replace(self, result=result)

    # -------------------------------------------------------------- queries
    @property
    def result_is_current(self) -> bool:
        """There is a result and it was made from this surface with these settings."""
        r = self.result
        return r is not None and r.surface is self.surface and settings_equal(r.settings, self.settings)

    @property
    def metres_per_unit(self) -> float:
        return UNITS[self.units]

    def fabric(self, name: str) -> Fabric | None:
        """The materials table's row called ``name``, or None."""
        return next((f for f in self.materials if f.name == name), None)

    @property
    def pieces(self) -> tuple[Piece, ...]:
        """Every piece in order, the active one (this project's settings and result) at :attr:`piece_index`."""
        return pieces_of(self)


def check_sewings(sewings, pieces) -> None:
    """A one-line SettingsError unless each sewing's panels are pieces of the project on its surface,
    no piece is a panel twice, and the sewings' names are distinct."""
    by_name = {p.name: p for p in pieces}
    seen, names = set(), set()
    for s in sewings:
        if not isinstance(s, Sewing):
            raise TypeError(f"a project's sewings must be Sewings, got {type(s).__name__}")
        key = s.name.strip().casefold()
        if key in names:
            raise SettingsError(f"two shapes split by seams are named {s.name!r}")
        names.add(key)
        for name in s.panels:
            if name is None:
                continue
            piece = by_name.get(name)
            if piece is None:
                raise SettingsError(f"seams of {s.name!r}: its panel {name!r} is not a piece of the project")
            if piece.surface is not s.surface:
                raise SettingsError(f"seams of {s.name!r}: its panel {name!r} lies on another surface")
            if name in seen:
                raise SettingsError(f"piece {name!r} is a panel of two shapes")
            seen.add(name)


def table_for(pieces) -> tuple[Fabric, ...]:
    """A materials table for ``pieces``: the bundled presets, then each material a piece uses that
    is not among them (its mechanics only: no roll width, thickness or weight known)."""
    table = list(FABRICS.values())
    names = {f.name for f in table}
    for p in pieces:
        m = p.settings.material
        if m.name not in names:
            table.append(Fabric(m))
            names.add(m.name)
    return tuple(table)


# ---------------------------------------------------------------------- settings <-> dict
def _darts_to_list(darts, labels: bool = True) -> list[dict]:
    """The darts as JSON objects; ``labels=False`` keeps only what decides the
    cut (kind, plane and box, or the (u, v) curve), not the name, visibility,
    or a curve dart's drawn points and direction."""
    return [d.to_dict(None if labels else CUT_DART_KEYS) for d in darts]


def _yarns_to_list(yarns) -> list[dict]:
    return [y.to_dict() for y in yarns]


class _Fields:
    """Typed reads from a JSON object with one-line errors naming the entry."""

    def __init__(self, where: str):
        self.where = where

    def fail(self, message: str) -> ProjectError:
        return ProjectError(f"{self.where}: {message}")

    def obj(self, value: Any, what: str) -> dict:
        if not isinstance(value, dict):
            raise self.fail(f"{what} must be an object, got {type(value).__name__}")
        return value

    def get(self, d: dict, key: str, what: str) -> Any:
        if key not in d:
            raise self.fail(f"{what} has no {key!r}")
        return d[key]

    def number(self, value: Any, what: str, allow_none: bool = False) -> float | None:
        if value is None and allow_none:
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.fail(f"{what} must be a finite number, got {value!r:.60}")
        return float(value)

    def integer(self, value: Any, what: str) -> int:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or value != int(value):
            raise self.fail(f"{what} must be an integer, got {value!r:.60}")
        return int(value)

    def string(self, value: Any, what: str) -> str:
        if not isinstance(value, str):
            raise self.fail(f"{what} must be a string, got {value!r:.60}")
        return value

    def numbers(self, value: Any, n: int, what: str) -> tuple[float, ...]:
        if not isinstance(value, list) or len(value) != n:
            raise self.fail(f"{what} must be a list of {n} numbers")
        return tuple(self.number(x, what) for x in value)

    def points(self, value: Any, what: str) -> np.ndarray:
        """(k, 2) from a list of [u, v] points."""
        if not isinstance(value, list) or not all(isinstance(p, list) for p in value):
            raise self.fail(f"{what} must be a list of [u, v] points")
        return np.array([self.numbers(p, 2, what) for p in value], dtype=float).reshape(-1, 2)


def _material_from(f: _Fields, value: Any) -> Material:
    m = f.obj(value, "settings.material")
    name = f.string(f.get(m, "name", "settings.material"), "settings.material.name")
    ks = [f.number(f.get(m, k, "settings.material"), f"settings.material.{k}") for k in ("k_weft", "k_warp", "k_diag")]
    # the angles came with version 3's materials; older files judged by 15 and 30 degrees
    angles = [f.number(m.get(k, d), f"settings.material.{k}") for k, d in (("warn_deg", 15.0), ("lock_deg", 30.0))]
    material = Material(name, *ks, *angles)
    preset = MATERIALS.get(name)
    if preset is not None and preset == material:
        return preset
    if preset is not None:
        # a preset's name whose constants are another preset's: the file was written when the name meant
        # those constants ("isotropic" was 100:100:100 before version 3), so it opens as what it was
        for p in MATERIALS.values():
            if p.same_constants(material) and (p.warn_deg, p.lock_deg) == tuple(angles):
                return p
    return material


def settings_from_dict(d: Any, darts: Any = (), yarns: Any = (), where: str = "project") -> FlattenSettings:
    """FlattenSettings from :func:`settings_to_dict`'s form (and dart and yarn lists).

    Raises ProjectError (a malformed entry) or SettingsError (a value no solve can use).
    """
    f = _Fields(where)
    d = f.obj(d, "settings")
    for key in _SETTINGS_KEYS:
        f.get(d, key, "settings")
    max_seconds = f.number(d["max_seconds"], "settings.max_seconds", allow_none=True)
    values = dict(
        spacing=f.number(d["spacing"], "settings.spacing"),
        spacing_warp=f.number(d["spacing_warp"], "settings.spacing_warp", allow_none=True),
        material=_material_from(f, d["material"]),
        seed=f.numbers(d["seed"], 2, "settings.seed"),
        angle_deg=f.number(d["angle_deg"], "settings.angle_deg"),
        paths=f.string(d["paths"], "settings.paths"),
        solver=f.string(d["solver"], "settings.solver"),
        tol=f.number(d["tol"], "settings.tol"),
        max_iter=f.integer(d["max_iter"], "settings.max_iter"),
        max_seconds=math.inf if max_seconds is None else max_seconds,
        max_nodes=f.integer(d["max_nodes"], "settings.max_nodes"),
        region=_region_from(f, d.get("region")),
        darts=_darts_from(f, darts),
        yarns=_yarns_from(f, yarns),
    )
    if "ease" in d:  # a matched seam's panel (flatweave.document.matching)
        try:
            values["ease"] = ease_from_list(d["ease"])
        except SettingsError as exc:
            raise f.fail(f"settings.ease: {exc}") from None
    try:
        out = FlattenSettings(**values)
        validate_settings(out, job=True)
    except SettingsError as exc:
        raise ProjectError(f"{where}: {exc}") from None
    return out


def _region_from(f: _Fields, value: Any):
    """settings.region: null (the whole domain) or :meth:`flatweave.geometry.region.Region.to_dict`'s form."""
    if value is None:
        return None
    try:
        return Region.from_dict(value)
    except SettingsError as exc:
        raise f.fail(f"settings.region: {exc}") from None


def _darts_from(f: _Fields, value: Any) -> tuple:
    if not isinstance(value, (list, tuple)):
        raise f.fail("darts must be a list")
    return tuple(dart_from_dict(item, f, f"darts[{k}]") for k, item in enumerate(value))


def _yarns_from(f: _Fields, value: Any) -> tuple:
    if not isinstance(value, (list, tuple)):
        raise f.fail("yarns must be a list")
    out = []
    for k, item in enumerate(value):
        what = f"yarns[{k}]"
        item = f.obj(item, what)
        try:
            out.append(YarnConstraint.from_dict(item, f, what))
        except SettingsError as exc:
            raise f.fail(f"{what}: {exc}") from None
    return tuple(out)


_KEYS: dict[int, str] = {}
"""_settings_key of live settings objects, by id (settings are frozen; a window compares the same ones
a dozen times an edit, and a curve dart's points make each key a few hundred numbers of JSON)."""


def _settings_key(s: FlattenSettings) -> str:
    key = _KEYS.get(id(s))
    if key is None:
        key = _KEYS[id(s)] = _make_settings_key(s)
        weakref.finalize(s, _KEYS.pop, id(s), None)
    return key


def _make_settings_key(s: FlattenSettings) -> str:
    d = settings_to_dict(s, "project")
    if d["spacing_warp"] is None:  # the same drape as an explicit warp spacing equal to the weft's
        d["spacing_warp"] = d["spacing"]
    # a picked yarn is its point: the index it resolves to follows from the drape
    return json.dumps([d, _darts_to_list(s.darts, labels=False), [y.identity() for y in s.yarns]], sort_keys=True)


def settings_equal(a: FlattenSettings, b: FlattenSettings) -> bool:
    """Settings that make the same solve: equal values, darts and yarns included
    (dataclass ``==`` cannot compare curve darts, whose points are arrays), but
    not the darts' labels (names, visibility), which never change a result."""
    return a is b or _settings_key(a) == _settings_key(b)


def labels_equal(a: FlattenSettings, b: FlattenSettings) -> bool:
    """The darts agree in what :func:`settings_equal` leaves out: names,
    visibility and a curve dart's drawn points and direction."""
    return a is b or json.dumps(_darts_to_list(a.darts)) == json.dumps(_darts_to_list(b.darts))


def needs_new_drape(old: FlattenSettings, new: FlattenSettings) -> bool:
    """True when going from ``old`` to ``new`` changes the drape (spacing, seed,
    weft angle, paths, node limit); other changes (material, solver, tolerance,
    darts, yarns) can warm-start from the old equilibrium."""
    a, b = settings_to_dict(old, "project"), settings_to_dict(new, "project")
    return any(a[k] != b[k] for k in DRAPE_KEYS)


def drops_a_dart(old: FlattenSettings, new: FlattenSettings) -> bool:
    """True when a dart cut in ``old`` is not cut the same way in ``new``: it
    was moved, reshaped or deleted (labels do not count)."""
    kept = {json.dumps(d.to_dict(CUT_DART_KEYS)) for d in new.darts}
    return any(json.dumps(d.to_dict(CUT_DART_KEYS)) not in kept for d in old.darts)


def warm_start(project: Project) -> State | None:
    """The state a re-run of ``project`` can start from: its last result's mesh,
    when that result is on the same surface and drape and every dart it cut is
    still cut there (a new dart opens from it); else None (drape anew).

    A result whose dart moved or went away holds the old dart's opening, which
    the restored springs have to close: that start ends in another, worse
    minimum, and more slowly than a new drape
    (docs/decisions/0035-a-moved-or-deleted-dart-drapes-anew.md)."""
    r = project.result
    if r is None or not solver_entry(project.settings.solver).warm_start or r.surface is not project.surface \
            or needs_new_drape(r.settings, project.settings) \
            or drops_a_dart(r.settings, project.settings):
        return None
    return r.state()


# ---------------------------------------------------------------------- project <-> dict
def project_to_dict(project: Project) -> dict:
    """The project file's content (see the module docstring)."""
    p = project
    sources = sources_of(p)
    where = {k: i for i, (_, _, ks) in enumerate(sources) for k in ks}
    return {
        "format": PROJECT_FORMAT,
        "version": PROJECT_VERSION,
        "flatweave": __version__,
        "name": p.name,
        "sources": [_source_doc(surface, source) for surface, source, _ in sources],
        "display": {"units": p.units, "shear_warning_deg": float(p.shear_warning_deg),
                    "shear_limit_deg": float(p.shear_limit_deg), **({"view": dict(p.view)} if p.view else {})},
        "pieces": [_piece_doc(piece, where[k]) for k, piece in enumerate(p.pieces)],
        "current": p.piece_index,
        "materials": [f.to_dict() for f in p.materials],
        **({"rosettes": [r.to_dict() for r in p.rosettes]} if p.rosettes else {}),
        **({"sewings": [s.to_dict(_source_of(sources, s.surface)) for s in p.sewings]} if p.sewings else {}),
        **({"cut_plan": p.cut_plan.to_dict()} if not p.cut_plan.is_default else {}),
    }


def _source_of(sources, surface) -> int:
    """The index in ``sources`` (:func:`flatweave.document.pieces.sources_of`) of ``surface``."""
    return next(i for i, (s, _, _) in enumerate(sources) if s is surface)


def _source_doc(surface: NurbsSurface, source: str | None) -> dict:
    """One entry of the file's ``sources``: where the surface came from, the surface, and a mesh
    fit's record (flatweave.geometry.meshfit.MeshFit) when it was fitted to a mesh."""
    return {"source": source, "surface": surface_to_json_dict(surface),
            **({"surface_fit": surface.fit.to_dict()} if getattr(surface, "fit", None) is not None else {})}


def _piece_doc(piece: Piece, source: int) -> dict:
    """One entry of the file's ``pieces``; ``source`` the index of its surface in ``sources``."""
    return {
        "name": piece.name,
        "source": source,
        "quantity": piece.quantity,
        "sequence": piece.sequence,
        **({"rosette": piece.rosette, "orientation": float(piece.orientation)} if piece.rosette is not None else {}),
        "settings": settings_to_dict(piece.settings, "project"),
        "darts": _darts_to_list(piece.settings.darts),
        "yarns": _yarns_to_list(piece.settings.yarns),
        "result": None if piece.result is None else _result_doc(piece.result),
        **_candidates_entry(piece),
    }


def _candidates_entry(p) -> dict:
    """The optional ``candidates`` key (flatweave.document.candidates): absent when no region is kept or named."""
    entry = candidates_to_dict(p)
    return {} if entry is None else {"candidates": entry}


def _result_doc(result: FlattenResult) -> dict:
    """What the project keeps of a result: what rebuilds it, and its energy history."""
    doc = result_state_dict(result)
    doc["history"] = [float(e) for e in result.history]
    return doc


def _upgrade_1_to_2(d: dict) -> dict:
    """Version 1 had no energy history in the result: an empty one."""
    d = dict(d)
    if isinstance(d.get("result"), dict):
        d["result"] = {**d["result"], "history": []}
    d["version"] = 2
    return d


def _upgrade_2_to_3(d: dict) -> dict:
    """Version 2 had no result warnings (they are made from the saved metrics
    when the result is read) and no picked yarn points (its yarns are
    explicit lattice indices, as version 3 reads a yarn without a point)."""
    d = dict(d)
    d["version"] = 3
    return d


def _upgrade_3_to_4(d: dict) -> dict:
    """Version 3 had no region: every piece was its surface's whole domain (``settings.region`` null)."""
    d = dict(d)
    if isinstance(d.get("settings"), dict):
        d["settings"] = {**d["settings"], "region": None}
    d["version"] = 4
    return d


def _upgrade_4_to_5(d: dict) -> dict:
    """Version 4 held one piece in the project itself: that piece, named after the project, one to cut."""
    d = dict(d)
    name = d.get("name")
    piece = {"name": name if isinstance(name, str) and name.strip() else "piece 1", "quantity": 1, "sequence": None}
    for key in ("settings", "darts", "yarns", "result", "candidates"):
        if key in d:
            piece[key] = d.pop(key)
    d["pieces"], d["current"], d["version"] = [piece], 0, 5
    return d


def _upgrade_5_to_6(d: dict) -> dict:
    """Version 5 had one surface for every piece: the only source, every piece on it."""
    d = dict(d)
    source = {"source": d.pop("source", None), "surface": d.pop("surface", None)}
    if "surface_fit" in d:
        source["surface_fit"] = d.pop("surface_fit")
    d["sources"] = [source]
    if isinstance(d.get("pieces"), list):
        d["pieces"] = [{**p, "source": 0} if isinstance(p, dict) else p for p in d["pieces"]]
    d["version"] = 6
    return d


def _upgrade_6_to_7(d: dict) -> dict:
    """Version 6 had no seams: no shape split into panels (the optional ``sewings`` absent)."""
    d = dict(d)
    d["version"] = 7
    return d


def _upgrade_7_to_8(d: dict) -> dict:
    """Version 7 had no cut plan (the optional ``cut_plan`` absent: nesting as made)."""
    d = dict(d)
    d["version"] = 8
    return d


UPGRADES = {1: _upgrade_1_to_2, 2: _upgrade_2_to_3, 3: _upgrade_3_to_4, 4: _upgrade_4_to_5, 5: _upgrade_5_to_6,
            6: _upgrade_6_to_7, 7: _upgrade_7_to_8}
"""Version -> the function that turns a document of that version into one of the next."""


def result_from_dict(d: Any, surface: NurbsSurface, where: str = "project") -> FlattenResult:
    """A FlattenResult from a result document (:func:`flatweave.method.pipeline.result_to_dict`).

    The mesh is rebuilt from the nodes' lattice positions and (u, v), and xyz,
    the pattern and the dart openings are recomputed by the pipeline (with the
    solver off), so they equal the saved ones; the metrics and drape
    statistics are the saved ones (the recomputation does not know how many
    iterations the solve took).
    """
    f = _Fields(where)
    d = f.obj(d, "result")
    s = f.obj(f.get(d, "settings", "result"), "result.settings")
    settings = settings_from_dict(s, s.get("darts", []), s.get("yarns", []), where=f"{where}: result")
    metrics = f.obj(f.get(d, "metrics", "result"), "result.metrics")
    stats = f.obj(d.get("drape", {}), "result.drape")
    nodes = f.obj(f.get(d, "nodes", "result"), "result.nodes")
    try:
        ij = decode_array(f.get(nodes, "ij", "result.nodes"), "result.nodes.ij", SettingsError).astype(float)
        uv = decode_array(f.get(nodes, "uv", "result.nodes"), "result.nodes.uv", SettingsError).astype(float)
        ij, uv = ij.reshape(-1, 2), uv.reshape(-1, 2)
    except (SettingsError, TypeError, ValueError) as exc:
        raise f.fail(f"result.nodes.ij and .uv must be lists of number pairs ({exc})") from None
    if len(ij) == 0 or len(ij) != len(uv):
        raise f.fail(f"result.nodes has {len(ij)} lattice positions and {len(uv)} (u, v): not one per node")
    if not (np.isfinite(ij).all() and np.array_equal(ij, np.round(ij))):
        raise f.fail("result.nodes.ij must be integer lattice positions")
    if not (np.isfinite(uv).all() and surface.in_domain(uv).all()):
        raise f.fail("result.nodes.uv lie outside the surface's domain")
    state = state_from_dict(d, surface, settings)
    area = metrics.get("area_3d")
    area = float(area) if isinstance(area, (int, float)) and not isinstance(area, bool) and area > 0 else None
    gen = flatten_iter(surface, replace(settings, solver="none"), initial=state, area=area)
    try:
        next(gen)
    except StopIteration as done:
        rebuilt = done.value
    else:  # the pipeline never yields without a solver
        raise AssertionError("flatten_iter yielded with the solver off")
    history = d.get("history", [])
    if not (isinstance(history, list) and all(isinstance(e, (int, float)) and not isinstance(e, bool)
                                               and math.isfinite(e) for e in history)):
        raise f.fail("result.history must be a list of finite energies")
    metrics = dict(metrics)
    # measured on the rebuilt mesh when the file has none: coverage before version 3, the piece's
    # curvature and the fit's share of the mesh's size before the limits scaled with them
    for key in ("uncovered_pct", "max_gap_spacings", "total_curvature", "fit_max_deviation_pct",
                "fit_mean_deviation_pct"):
        if key in rebuilt.metrics:
            metrics.setdefault(key, rebuilt.metrics[key])
    if "nodes_deleted_pct" not in metrics:
        deleted, refilled, n = (metrics.get(k) for k in ("nodes_deleted", "nodes_refilled", "nodes"))
        if all(isinstance(v, int) and not isinstance(v, bool) for v in (deleted, refilled, n)):
            metrics["nodes_deleted_pct"] = 100.0 * deleted / max(n + deleted - refilled, 1)
    result = replace(rebuilt, settings=settings, metrics=metrics, drape_stats=dict(stats),
                     history=tuple(float(e) for e in history))
    warnings = d.get("warnings")
    if warnings is not None and not (isinstance(warnings, list) and all(isinstance(w, str) for w in warnings)):
        raise f.fail("result.warnings must be a list of texts")
    # judged anew from the saved metrics: a file saved before a limit changed tells today's truth
    return judged(result)


def project_from_dict(d: Any, where: str = "project") -> Project:
    """A Project from a project document; one-line ProjectError on any problem."""
    f = _Fields(where)
    if not isinstance(d, dict):
        raise f.fail(f"not a flatweave project (the file holds {type(d).__name__}, not an object)")
    fmt = d.get("format")
    if fmt != PROJECT_FORMAT:
        if fmt == "flatweave-result":
            raise f.fail("this is a flatweave result file, not a project; open its surface instead")
        raise f.fail(f"not a flatweave project (format {fmt!r:.40}, expected {PROJECT_FORMAT!r})")
    version = d.get("version")
    if isinstance(version, bool) or not isinstance(version, int):
        raise f.fail(f"project version must be an integer, got {version!r:.40}")
    if version > PROJECT_VERSION:
        raise f.fail(f"saved by a newer flatweave (project version {version}; this flatweave "
                     f"{__version__} reads versions up to {PROJECT_VERSION})")
    if version < 1:
        raise f.fail(f"project version {version} is not a valid version")
    while version < PROJECT_VERSION:
        d = UPGRADES[version](d)
        version = d["version"]
    docs = f.get(d, "sources", "project")
    if not isinstance(docs, list) or not 1 <= len(docs) <= MAX_PIECES:
        raise f.fail(f"sources must be a list of 1 to {MAX_PIECES} surfaces")
    sources = [_source_from(f, doc, k, where) for k, doc in enumerate(docs)]
    display = f.obj(d.get("display", {}), "display")
    view = f.obj(display.get("view", {}), "display.view")
    if not all(isinstance(k, str) and isinstance(v, (str, bool)) for k, v in view.items()):
        raise f.fail("display.view must map names to strings or true/false")
    name = d.get("name", "untitled")
    docs = f.get(d, "pieces", "project")
    if not isinstance(docs, list) or not 1 <= len(docs) <= MAX_PIECES:
        raise f.fail(f"pieces must be a list of 1 to {MAX_PIECES} pieces")
    current = f.integer(d.get("current", 0), "current")
    if not 0 <= current < len(docs):
        raise f.fail(f"current is {current}, but the project has {len(docs)} pieces")
    rows = d.get("rosettes", [])  # optional: a file without rosettes orients its pieces by weft angle alone
    if not isinstance(rows, list) or len(rows) > MAX_ROSETTES:
        raise f.fail(f"rosettes must be a list of at most {MAX_ROSETTES} rosettes")
    try:
        # the pieces' weft angles are read as saved (as they were solved), not recomputed from the rosettes
        rosettes = tuple(ToolRosette.from_dict(r, f"rosettes[{k}]") for k, r in enumerate(rows))
        pieces = [_piece_from(f, doc, k, sources, where) for k, doc in enumerate(docs)]
        project = Project(
            pieces[current].surface, pieces[current].settings,
            name=f.string(name, "name"),
            source=pieces[current].source,
            units=f.string(display.get("units", "m"), "display.units"),
            shear_warning_deg=f.number(display.get("shear_warning_deg", 15.0), "display.shear_warning_deg"),
            shear_limit_deg=f.number(display.get("shear_limit_deg", 30.0), "display.shear_limit_deg"),
            view=tuple(sorted(view.items())), piece_name=pieces[current].name, rosettes=rosettes)
        project = with_pieces(project, pieces, current)
        rows = d.get("sewings", [])  # optional: no shape split by seams
        if not isinstance(rows, list) or len(rows) > MAX_PIECES:
            raise f.fail(f"sewings must be a list of at most {MAX_PIECES} shapes split by seams")
        if rows:
            project = replace(project, sewings=tuple(_sewing_from(f, r, k, sources) for k, r in enumerate(rows)))
        plan = d.get("cut_plan")  # optional: nested as made
        if plan is not None:
            try:
                project = replace(project, cut_plan=CutPlanSettings.from_dict(plan))
            except SettingsError as exc:
                raise f.fail(f"cut_plan: {exc}") from None
        rows = d.get("materials")  # optional: a file without a table gets the presets and the pieces' own
        if rows is not None:
            if not isinstance(rows, list) or not rows or len(rows) > 200:
                raise f.fail("materials must be a list of 1 to 200 materials")
            project = replace(project, materials=tuple(Fabric.from_dict(r, f"materials[{k}]")
                                                       for k, r in enumerate(rows)))
    except SettingsError as exc:
        raise ProjectError(f"{where}: {exc}") from None
    return project


def _source_from(f: _Fields, doc: Any, k: int, where: str) -> tuple[NurbsSurface, str | None]:
    """Source ``k`` of the file's ``sources``: its surface (with its mesh fit) and where it came from."""
    what = f"sources[{k}]"
    doc = f.obj(doc, what)
    source = doc.get("source")
    source = None if source is None else f.string(source, f"{what}.source")
    try:
        surface = surface_from_json_dict(f.get(doc, "surface", what), source=f"{where}: {what}.surface")
        if doc.get("surface_fit") is not None:  # fitted to a mesh: the mesh file is not needed again
            surface = with_fit(surface, MeshFit.from_dict(doc["surface_fit"]))
    except FlatweaveError as exc:
        raise ProjectError(f"{where}: {exc}" if not str(exc).startswith(where) else str(exc)) from None
    return surface, source


def _sewing_from(f: _Fields, doc: Any, k: int, sources: list) -> Sewing:
    """Sewing ``k`` of the file's ``sewings``, on its source of ``sources``."""
    what = f"sewings[{k}]"
    doc = f.obj(doc, what)
    at = f.integer(doc.get("source", 0), f"{what}.source")
    if not 0 <= at < len(sources):
        raise f.fail(f"{what}.source is {at}, but the project has {len(sources)} sources")
    seams, panels = f.get(doc, "seams", what), f.get(doc, "panels", what)
    if not isinstance(seams, list) or not isinstance(panels, list) \
            or not all(p is None or isinstance(p, str) for p in panels):
        raise f.fail(f"{what}: seams must be a list of seams and panels a list of piece names")
    region = doc.get("region")
    try:
        sewing = Sewing(f.string(f.get(doc, "name", what), f"{what}.name"), *sources[at],
                        None if region is None else Region.from_dict(region),
                        tuple(SeamLine.from_dict(s, f"{what}.seams[{j}]") for j, s in enumerate(seams)),
                        tuple(panels))
    except SettingsError as exc:
        raise f.fail(f"{what}: {exc}") from None
    # the split must give as many panels as the file names (a seam moved by hand in the file, say)
    from_split = len(split_of(sewing).panels)
    if from_split != len(sewing.panels):
        raise f.fail(f"{what}: its seams split it into {from_split} panels, but it names {len(sewing.panels)}")
    return sewing


def _piece_from(f: _Fields, doc: Any, k: int, sources: list, where: str) -> Piece:
    """Piece ``k`` of the file's ``pieces``, on its source of ``sources``."""
    what = f"pieces[{k}]"
    doc = f.obj(doc, what)
    at = f.integer(doc.get("source", 0), f"{what}.source")
    if not 0 <= at < len(sources):
        raise f.fail(f"{what}.source is {at}, but the project has {len(sources)} sources")
    surface, source = sources[at]
    name = f.string(f.get(doc, "name", what), f"{what}.name")
    here = f"{where}: piece {name!r}"
    settings = settings_from_dict(f.get(doc, "settings", what), doc.get("darts", []), doc.get("yarns", []), here)
    sequence = doc.get("sequence")
    region_name, kept = candidates_from_dict(doc.get("candidates"))
    rosette = doc.get("rosette")
    orientation = None if rosette is None else f.number(doc.get("orientation"), f"{what}.orientation")
    piece = Piece(name, settings, None, region_name, kept, doc.get("quantity", 1),
                  None if sequence is None else sequence, rosette, orientation, surface, source)
    if doc.get("result") is not None:
        piece = replace(piece, result=result_from_dict(doc["result"], surface, here))
    return piece


# ---------------------------------------------------------------------- files
def save_project(project: Project, path: str | os.PathLike) -> Path:
    """Write ``project`` to ``path`` atomically (the old file survives any failure).

    Returns the path. Raises a one-line FlatweaveError when it cannot be written.
    """
    path = Path(path)
    write_json(path, project_to_dict(project))
    return path


def load_project(path: str | os.PathLike) -> Project:
    """Read a ``.flatweave`` file; one-line ProjectError naming the file on any problem."""
    name = os.fspath(path)
    raw = read_input(name, "result", ProjectError)
    if not raw.strip():
        raise ProjectError(f"{name}: file is empty")
    check_json_depth(raw, name, "flatweave project", ProjectError)
    try:
        doc = json.loads(raw.decode("utf-8-sig"))
    except UnicodeDecodeError:
        raise ProjectError(f"{name}: not a flatweave project (binary data, not JSON text)") from None
    except json.JSONDecodeError as exc:
        raise ProjectError(f"{name}: damaged or not a flatweave project (invalid JSON at line {exc.lineno}, "
                           f"column {exc.colno}: {exc.msg})") from None
    except (RecursionError, ValueError) as exc:
        raise ProjectError(f"{name}: not usable JSON ({type(exc).__name__})") from None
    try:
        return project_from_dict(doc, where=name)
    except FlatweaveError:
        raise
    except (KeyError, TypeError, ValueError, IndexError) as exc:  # damage the checks above did not name
        first = str(exc).splitlines()[0] if str(exc) else ""
        raise ProjectError(f"{name}: damaged project ({type(exc).__name__}: {first})") from None


# ---------------------------------------------------------------------- consistency
def project_problems(project: Project) -> list[str]:
    """What is inconsistent in a project (empty when all is well).

    Checks the result's arrays against its mesh: node counts of uv, xyz and
    the pattern, springs indexing existing nodes, xyz on the surface at uv,
    a closed outline, finite numbers. For tests and the soak test.
    """
    problems = []
    r = project.result
    if r is None:
        return problems
    n = r.mesh.n_nodes
    if r.uv.shape != (n, 2):
        problems.append(f"uv has shape {r.uv.shape}, mesh has {n} nodes")
    if r.xyz.shape != (n, 3):
        problems.append(f"xyz has shape {r.xyz.shape}, mesh has {n} nodes")
    if r.pattern.xy.shape != (n, 2):
        problems.append(f"pattern xy has shape {r.pattern.xy.shape}, mesh has {n} nodes")
    if len(r.mesh.ends) and (r.mesh.ends.min() < 0 or r.mesh.ends.max() >= n):
        problems.append("springs refer to missing nodes")
    if not problems:
        if not (np.isfinite(r.uv).all() and np.isfinite(r.xyz).all()):
            problems.append("non-finite node positions")
        elif n and np.abs(r.surface.points(r.uv) - r.xyz).max() > 1e-9 * max(1.0, r.surface.bbox_diagonal()):
            problems.append("xyz is not the surface at uv")
    if not problems and n and r.settings.region is not None:
        if not cover_for(r.surface, r.settings.region).contains(r.uv).all():
            problems.append("nodes lie outside the piece's region")
    if len(r.pattern.outline) < 3:
        problems.append("the pattern has no outline")
    for key in ("energy", "boundary_error_pct", "area_error_pct", "nodes"):
        if key not in r.metrics:
            problems.append(f"metrics lack {key!r}")
    if "nodes" in r.metrics and r.metrics["nodes"] != n:
        problems.append(f"metrics say {r.metrics['nodes']} nodes, mesh has {n}")
    return problems


def new_project(surface: NurbsSurface, name: str = "untitled", source: str | None = None,
                spacing: float | None = None, units: str = "m", region=None) -> Project:
    """A project with default settings for ``surface``: the woven material and,
    unless given, a spacing of about a 25th of the square root of its area
    (rounded to two significant digits), which makes about 600 nodes. With a
    ``region`` (a trimmed face, :class:`flatweave.geometry.region.Region`) the area is the
    region's and the seed its point farthest from its edge."""
    if region is None:
        area, extra = float(region_area(surface)), {}
    else:
        cover = cover_for(surface, region)
        area, extra = cover.area, {"region": region, "seed": cover.default_seed}
    if spacing is None:
        raw = math.sqrt(area) / 25.0
        spacing = float(f"{raw:.2g}") if raw > 0 and math.isfinite(raw) else 1.0
    return Project(surface, FlattenSettings(spacing=float(spacing), **extra), name=name, source=source, units=units)
