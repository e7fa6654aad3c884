"""Job files (issue 41): a laminate, or any set of pieces on a tool's surfaces, as a
TOML file, so a hundred plies need no clicking. Read into a project
(:func:`load_job`, the reader of ``.toml`` in :mod:`flatweave.reading.registry`),
then solved like any project (``flatweave-cli solve JOB.toml``)::

    name = "radome laminate"
    source = "dome"            # a surface, CAD, mesh file (relative to this file) or a bundled example
    face = 0                   # a CAD file's face, if it has several
    units = "m"                # the model's units (default the file's, else m)
    spacing = 0.08             # the plies' weft spacing unless a ply says
    material = "carbon plain weave 200"   # the plies' material unless a ply says

    [rosette]                  # or [[rosette]] tables with a "name" each
    origin = [0.0, 0.0, 1.0]
    zero = [1.0, 0.0, 0.0]     # the 0-degree direction on the tool

    [[material]]               # rows added to the bundled presets (flatweave.method.materials)
    name = "my twill"
    kind = "woven"             # or "isotropic", or ratio = "500:500:1"
    lock_deg = 40.0            # warn_deg, roll_width_mm, thickness_mm, areal_weight_gsm too

    [[ply]]
    name = "P01"
    sequence = 1
    orientation = 45           # degrees from the rosette's 0 direction, about the normal
    material = "my twill"      # rosette, spacing, quantity too
    boundary = { uv = [[0.2, 0.2], [0.8, 0.2], [0.8, 0.8], [0.2, 0.8]] }   # any --region form
    offset = -0.005            # the boundary moved along the surface (negative: inwards)
    face = 2                   # on another face of the source (or source = "OTHER FILE"): the
                               # job's sources are every (source, face) its plies name, each opened once

A ply's orientation is measured at its seed (its region's point farthest from
the edge) from the rosette's 0 direction projected on the tangent plane there
(the projection rosette of composites tools), about the surface's normal.
Every problem is one line naming the file and the line of the entry.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import replace
from pathlib import Path
from typing import Any

from flatweave.document.pieces import Piece, with_pieces
from flatweave.document.rosettes import ToolRosette, piece_weft
from flatweave.document.project import Project, UNITS
from flatweave.errors import FlatweaveError, SettingsError
from flatweave.files import exists, read_input
from flatweave.geometry.region import cover_for, offset_region, region_from_spec
from flatweave.method.lattice import MATERIALS, Material, parse_material
from flatweave.method.materials import FABRICS, Fabric
from flatweave.method.settings import FlattenSettings

__all__ = ["load_job", "JOB_SUFFIX"]

JOB_SUFFIX = ".toml"
PLY_KEYS = {"name", "sequence", "orientation", "material", "rosette", "spacing", "quantity", "boundary", "offset",
            "source", "face"}


class _Lines:
    """The line numbers of a TOML file's array-of-tables headers (``[[ply]]``...), to name in messages."""

    def __init__(self, text: str, path: str):
        self.path = path
        self.headers: dict[str, list[int]] = {}
        for n, line in enumerate(text.splitlines(), 1):
            s = line.strip()
            if s.startswith("[[") and "]]" in s:
                self.headers.setdefault(s[2:s.index("]]")].strip(), []).append(n)
            elif s.startswith("[") and "]" in s:
                self.headers.setdefault(s[1:s.index("]")].strip(), []).append(n)

    def fail(self, table: str, k: int, message: str) -> SettingsError:
        lines = self.headers.get(table, [])
        at = f":{lines[k]}" if k < len(lines) else ""
        return SettingsError(f"{self.path}{at}: {message}")


def _number(value: Any, what: str, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or (positive and value <= 0):
        raise SettingsError(f"{what} must be a {'positive ' if positive else ''}number, got {value!r:.40}")
    return float(value)


def _vector(value: Any, what: str, nonzero: bool = False):
    if not isinstance(value, list) or len(value) != 3:
        raise SettingsError(f"{what} must be [x, y, z], got {value!r:.60}")
    v = [_number(x, what) for x in value]
    if nonzero and math.hypot(*v) == 0:
        raise SettingsError(f"{what} must not be zero")
    return v


def _fabric(row: dict) -> Fabric:
    name = row.get("name")
    if not isinstance(name, str):
        raise SettingsError(f"a material needs a name, got {name!r:.40}")
    if "ratio" in row:
        base = parse_material(str(row["ratio"]))
    else:
        kind = row.get("kind", "woven")
        if kind not in ("woven", "isotropic"):
            raise SettingsError(f"material {name!r}: kind must be woven or isotropic (or give a ratio), got {kind!r}")
        base = MATERIALS[kind]
    material = Material(name, base.k_weft, base.k_warp, base.k_diag,
                        _number(row.get("warn_deg", base.warn_deg), f"material {name!r}: warn_deg"),
                        _number(row.get("lock_deg", base.lock_deg), f"material {name!r}: lock_deg"))
    return Fabric(material, *(row.get(k) for k in ("roll_width_mm", "thickness_mm", "areal_weight_gsm")))


def load_job(path, open_path) -> Project:
    """The project a job file describes (see the module docstring), unsolved; a one-line
    SettingsError naming the file and line on any problem. ``open_path(path_or_name,
    surface_only=True)`` opens its source (the registry's, which registers this reader)."""
    path = Path(path)
    raw = read_input(path, "small", SettingsError)
    try:
        text = raw.decode("utf-8-sig")
        data = tomllib.loads(text)
    except UnicodeDecodeError:
        raise SettingsError(f"{path}: not a job file (binary data, not TOML text)") from None
    except tomllib.TOMLDecodeError as exc:
        raise SettingsError(f"{path}: not a job file: {exc}") from None
    lines = _Lines(text, str(path))

    def top(message: str) -> SettingsError:
        return SettingsError(f"{path}: {message}")

    source = data.get("source")
    if not isinstance(source, str) or not source:
        raise top('a job names its surface: source = "FILE" (relative to the job file) or a bundled example')
    opened_once: dict = {}

    def surface_of(source, face):
        """(surface, region, opened, where) of ``source``'s ``face``, each opened once (its pieces share it)."""
        key = (source, _key(face))
        if key not in opened_once:
            src = path.parent / source
            opened = open_path(src if exists(src) else source, surface_only=True)
            opened = opened.choose_face(face)
            where = str(src if exists(src) else source)
            if face is not None:
                where = f"{where}#face={face}"
            opened_once[key] = (opened.surface, opened.region, opened, where)
        return opened_once[key]

    try:
        surface, base_region, opened, _ = surface_of(source, data.get("face"))
    except FlatweaveError as exc:
        raise top(f"source {source!r}: {exc}") from None
    units = data.get("units", getattr(opened, "units", None) or "m")
    if units not in UNITS:
        raise top(f"units must be one of {', '.join(UNITS)}, got {units!r:.20}")

    table = dict(FABRICS)
    rows = data.get("material", [])
    if isinstance(rows, str):  # the plies' default, not a table
        rows = []
    for k, row in enumerate(rows if isinstance(rows, list) else [rows]):
        try:
            f = _fabric(row if isinstance(row, dict) else {})
        except SettingsError as exc:
            raise lines.fail("material", k, str(exc)) from None
        table[f.name] = f

    rosettes = data.get("rosette", [])
    rosettes = [rosettes] if isinstance(rosettes, dict) else rosettes
    named = {}
    for k, r in enumerate(rosettes if isinstance(rosettes, list) else []):
        try:
            if not isinstance(r, dict):
                raise SettingsError("a rosette is a table with origin and zero")
            name = r.get("name", f"rosette {k + 1}")
            named[name] = ToolRosette(name, _vector(r.get("origin"), "the rosette's origin"),
                                      _vector(r.get("zero"), "the rosette's zero", nonzero=True))
        except SettingsError as exc:
            raise lines.fail("rosette", k, str(exc)) from None
    if not named:
        raise top("a job needs a rosette: [rosette] with origin = [x, y, z] and zero = [dx, dy, dz]")

    plies = data.get("ply")
    if not isinstance(plies, list) or not plies:
        raise top("a job needs one or more [[ply]] tables")
    default_spacing = data.get("spacing")
    default_material = data.get("material") if isinstance(data.get("material"), str) else None
    pieces, names = [], set()
    for k, ply in enumerate(plies):
        try:
            own = (ply.get("source", source), ply.get("face", data.get("face"))) if isinstance(ply, dict) \
                else (source, data.get("face"))
            if not isinstance(own[0], str) or not own[0]:
                raise SettingsError(f'its source must be a file name or a bundled example, got {own[0]!r:.40}')
            try:
                here = surface_of(*own)
            except FlatweaveError as exc:
                raise SettingsError(f"source {own[0]!r}" + (f" face {own[1]!r}" if own[1] is not None else "")
                                    + f": {exc}") from None
            piece = _ply(ply, here[0], here[1], table, named, default_spacing, default_material)
            pieces.append(replace(piece, surface=here[0], source=here[3]))
        except SettingsError as exc:
            name = ply.get("name") if isinstance(ply, dict) else None
            raise lines.fail("ply", k, f"ply {name!r}: {exc}" if isinstance(name, str) else str(exc)) from None
        key = pieces[-1].name.strip().casefold()
        if key in names:
            raise lines.fail("ply", k, f"two plies are named {pieces[-1].name!r}")
        names.add(key)
    used = {p.settings.material.name for p in pieces}
    materials = tuple(f for f in table.values() if f.name in used or f.name in FABRICS)
    name = data.get("name", path.stem)
    try:
        project = Project(pieces[0].surface, pieces[0].settings, name=str(name), source=pieces[0].source, units=units,
                          piece_name=pieces[0].name, materials=materials, rosettes=tuple(named.values()))
        return with_pieces(project, pieces, 0)
    except SettingsError as exc:
        raise top(str(exc)) from None


def _key(value: Any) -> str:
    """A hashable key of a TOML value (a face: a number, or a list of numbers)."""
    return repr(value)


def _ply(ply: Any, surface, base_region, table: dict, rosettes: dict, default_spacing, default_material) -> Piece:
    if not isinstance(ply, dict):
        raise SettingsError("a ply is a table of keys")
    unknown = sorted(set(ply) - PLY_KEYS)
    if unknown:
        raise SettingsError(f"unknown key {unknown[0]!r} (a ply takes {', '.join(sorted(PLY_KEYS))})")
    name = ply.get("name")
    if not isinstance(name, str):
        raise SettingsError(f"a ply needs a name, got {name!r:.40}")
    material_name = ply.get("material", default_material)
    if material_name is None:
        raise SettingsError("no material: give the ply one, or the job a default (material = \"...\")")
    if material_name not in table:
        raise SettingsError(f"unknown material {material_name!r} (the table: {', '.join(table)})")
    spacing = _number(ply.get("spacing", default_spacing), "its spacing", positive=True)
    orientation = _number(ply.get("orientation", 0.0), "its orientation (degrees)")
    ros_name = ply.get("rosette", next(iter(rosettes)))
    if ros_name not in rosettes:
        raise SettingsError(f"unknown rosette {ros_name!r:.40} (the job's: {', '.join(rosettes)})")
    region = base_region
    if "boundary" in ply:
        region = region_from_spec(surface, ply["boundary"])
    if "offset" in ply:
        region = offset_region(surface, region, _number(ply["offset"], "its offset"))
    cover = cover_for(surface, region)
    settings = FlattenSettings(spacing=spacing, material=table[material_name].material,
                               seed=cover.default_seed, angle_deg=0.0, region=region)
    piece = Piece(name, settings, quantity=ply.get("quantity", 1), sequence=ply.get("sequence"),
                  rosette=ros_name, orientation=orientation)
    return replace(piece, settings=replace(settings, angle_deg=piece_weft(surface, rosettes.values(), piece)))
