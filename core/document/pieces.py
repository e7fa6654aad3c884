"""The pieces of a project: the plies of a laminate, the panels of a product.

A project holds one or more pieces on its surface (issue 41). One of them is
active: the piece the window shows and its tools edit. The active piece lives
in the project's own fields (``settings``, ``result``, ``region_name``,
``candidates``, ``piece_name``, ``quantity``, ``sequence``), so every edit of a
piece is the edit it was when a project held one piece, and a project of one
piece is what a project always was; the other pieces ride in
``Project.others``, in order, with the active one at ``Project.piece_index``
among them (docs/decisions/0059). :func:`pieces_of` is the whole list; the
functions here edit it, each returning a new project (one undoable step in a
:class:`flatweave.document.history.Document`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

from flatweave.document.rosettes import check_rosettes, piece_weft, rosette_named
from flatweave.errors import SettingsError
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.method.rosette import orientation_for
from flatweave.method.result import FlattenResult
from flatweave.method.settings import FlattenSettings

__all__ = ["Piece", "MAX_PIECES", "MAX_QUANTITY", "check_piece", "pieces_of", "with_pieces", "select", "add",
           "duplicate", "remove", "rename", "move", "set_quantity", "set_sequence", "index_of", "use_material",
           "set_materials", "free_name", "orient", "set_rosettes", "follow_rosettes", "placed", "sources_of",
           "add_from", "resurface"]

MAX_PIECES = 1000  # a laminate has 10 to 200 plies, a product 5 to 30 panels
MAX_QUANTITY = 100_000  # copies of one piece cut for a job
MAX_NAME = 80  # characters of a piece's name


@dataclass(frozen=True, eq=False)
class Piece:
    """One piece: its name, its settings (region, darts, yarns, material and
    orientation as today), its last result (None: not solved; it may be
    stale, as a project's), its kept candidate regions, how many are cut
    (``quantity``) and, in a laminate, its place in the stack (``sequence``,
    1 the first laid on the tool; None outside a laminate)."""

    name: str
    settings: FlattenSettings
    result: FlattenResult | None = None
    region_name: str = ""
    candidates: tuple = ()
    quantity: int = 1
    sequence: int | None = None
    # the tool rosette its orientation is measured from (a name in Project.rosettes), and the
    # orientation in degrees (flatweave.document.rosettes); both None: the weft angle alone
    rosette: str | None = None
    orientation: float | None = None
    # the surface it lies on and where that came from (a file, a face of one, an example): one of the
    # project's sources, shared by identity with the other pieces on it (None only until the piece is
    # placed in a project, which puts it on the active piece's surface)
    surface: NurbsSurface | None = None
    source: str | None = None

    def __post_init__(self):
        check_piece(self.name, self.quantity, self.sequence, self.rosette, self.orientation)
        if self.surface is not None and not isinstance(self.surface, NurbsSurface):
            raise TypeError(f"a piece's surface must be a NurbsSurface, got {type(self.surface).__name__}")


def check_piece(name: Any, quantity: Any, sequence: Any, rosette: Any = None, orientation: Any = None) -> None:
    """A one-line SettingsError unless the name is a text of 1 to MAX_NAME
    characters (not only spaces), ``quantity`` a whole number 1 to
    MAX_QUANTITY, ``sequence`` None or a whole number 1 to MAX_PIECES, and
    ``rosette`` and ``orientation`` both None or a name and a finite angle."""
    if rosette is not None or orientation is not None:
        if not isinstance(rosette, str) or not rosette.strip():
            raise SettingsError(f"piece {name!r:.60}: an orientation is measured from a rosette; "
                                f"got rosette {rosette!r:.40}")
        if isinstance(orientation, bool) or not isinstance(orientation, (int, float)) \
                or not math.isfinite(orientation):
            raise SettingsError(f"piece {name!r:.60}: its orientation must be a finite angle in degrees, "
                                f"got {orientation!r:.40}")
    if not isinstance(name, str) or not name.strip() or len(name) > MAX_NAME or "\n" in name:
        raise SettingsError(f"a piece's name must be a line of 1 to {MAX_NAME} characters, got {name!r:.60}")
    if isinstance(quantity, bool) or not isinstance(quantity, int) or not 1 <= quantity <= MAX_QUANTITY:
        raise SettingsError(f"piece {name!r}: the quantity must be a whole number from 1 to {MAX_QUANTITY}, "
                            f"got {quantity!r:.40}")
    if sequence is not None and (isinstance(sequence, bool) or not isinstance(sequence, int)
                                 or not 1 <= sequence <= MAX_PIECES):
        raise SettingsError(f"piece {name!r}: the sequence must be a whole number from 1 to {MAX_PIECES} "
                            f"(or none), got {sequence!r:.40}")


def check_pieces(pieces) -> None:
    """A one-line SettingsError unless the pieces are 1 to MAX_PIECES with distinct names."""
    if not 1 <= len(pieces) <= MAX_PIECES:
        raise SettingsError(f"a project holds 1 to {MAX_PIECES} pieces, got {len(pieces)}")
    seen = set()
    for p in pieces:
        if not isinstance(p, Piece):
            raise TypeError(f"a project's other pieces must be Pieces, got {type(p).__name__}")
        key = p.name.strip().casefold()
        if key in seen:
            raise SettingsError(f"two pieces are named {p.name!r}: each piece needs a name of its own")
        seen.add(key)


def active_piece(project) -> Piece:
    """The project's active piece, from its own fields."""
    return Piece(project.piece_name, project.settings, project.result, project.region_name, project.candidates,
                 project.quantity, project.sequence, project.piece_rosette, project.orientation, project.surface,
                 project.source)


def placed(pieces, surface, source) -> tuple[Piece, ...]:
    """``pieces`` with those not yet on a surface put on ``surface`` (from ``source``)."""
    return tuple(p if p.surface is not None else replace(p, surface=surface, source=source) for p in pieces)


def sources_of(project) -> list[tuple]:
    """The project's sources: each distinct (surface, source) its pieces lie on, in the order of
    their first piece, as (surface, source, [piece indices])."""
    out, index = [], {}
    for k, p in enumerate(pieces_of(project)):
        key = (id(p.surface), p.source)
        if key not in index:
            index[key] = len(out)
            out.append((p.surface, p.source, []))
        out[index[key]][2].append(k)
    return out


def pieces_of(project) -> tuple[Piece, ...]:
    """Every piece of ``project`` in order, the active one at ``project.piece_index``."""
    k = project.piece_index
    return project.others[:k] + (active_piece(project),) + project.others[k:]


def with_pieces(project, pieces, index: int, sewings=None):
    """``project`` holding ``pieces`` (in that order) with ``pieces[index]`` active (and, given, the
    ``sewings`` (:mod:`flatweave.document.sewing`) naming them; by default the project's)."""
    pieces = placed(pieces, project.surface, project.source)
    if not 0 <= index < len(pieces):
        raise SettingsError(f"no piece {index + 1}: the project has {len(pieces)}")
    p = pieces[index]
    return replace(project, surface=p.surface, source=p.source, settings=p.settings, result=p.result,
                   region_name=p.region_name, candidates=p.candidates, piece_name=p.name, quantity=p.quantity,
                   sequence=p.sequence, piece_rosette=p.rosette, orientation=p.orientation,
                   others=pieces[:index] + pieces[index + 1:], piece_index=index,
                   sewings=project.sewings if sewings is None else tuple(sewings))


def _sewings_renamed(sewings, names: dict) -> tuple:
    """``sewings`` with their panels' piece names mapped by ``names`` (a name mapped to None: the piece is
    gone); a sewing none of whose panels is left goes too."""
    out = []
    for s in sewings:
        panels = tuple(names.get(n, n) if n is not None else None for n in s.panels)
        if any(n is not None for n in panels):
            out.append(s if panels == s.panels else replace(s, panels=panels))
    return tuple(out)


def index_of(project, k: Any) -> int:
    """A piece's index from an index or a name; a one-line SettingsError when there is none."""
    pieces = pieces_of(project)
    if isinstance(k, str):
        for i, p in enumerate(pieces):
            if p.name == k:
                return i
        raise SettingsError(f"no piece is named {k!r} (the pieces: {', '.join(p.name for p in pieces)[:200]})")
    if isinstance(k, bool) or not isinstance(k, int) or not 0 <= k < len(pieces):
        raise SettingsError(f"no piece {k!r}: the project has {len(pieces)}")
    return k


def select(project, k):
    """The project with piece ``k`` (an index or a name) active."""
    return with_pieces(project, pieces_of(project), index_of(project, k))


def free_name(taken, base: str, numbered: bool = False) -> str:
    """``base``, or "``base`` N" with the first N from 2 (from 1 when ``numbered``) that no name in
    ``taken`` has, case and outer spaces aside (as a project matches the names of its pieces,
    materials and rosettes)."""
    keys = {n.strip().casefold() for n in taken}
    if not numbered and base.strip().casefold() not in keys:
        return base
    n = 1 if numbered else 2
    while f"{base} {n}".casefold() in keys:
        n += 1
    return f"{base} {n}"


def add(project, name: str | None = None, settings: FlattenSettings | None = None, select_it: bool = True,
        surface: NurbsSurface | None = None, source: str | None = None):
    """The project with a new piece after the last: ``settings`` (default the
    active piece's, less its darts and yarns: a new piece on the same
    surface and material), named ``name`` (default "piece N"), unsolved; on
    ``surface`` from ``source`` (another of the job's sources: a face of the
    same CAD file, another file) or, by default, the active piece's."""
    pieces = pieces_of(project)
    if settings is None:
        if surface is not None:
            raise SettingsError("a piece on another surface needs its own settings (its region and seed are "
                                "that surface's)")
        settings = replace(project.settings, darts=(), yarns=())
    name = free_name((q.name for q in pieces), f"piece {len(pieces) + 1}") if name is None else name
    if surface is None:
        surface, source = project.surface, project.source
    new = pieces + (Piece(name, settings, surface=surface, source=source),)
    return with_pieces(project, new, len(new) - 1 if select_it else project.piece_index)


def add_from(project, other, select_it: bool = True):
    """The project with ``other``'s pieces (another project: a surface, a CAD face or a mesh
    opened on its own) added after the last, on ``other``'s surfaces, unsolved results kept.
    A name already taken gets a number; ``other``'s materials the table lacks are added
    (same name, other mechanics: refused) and so are its rosettes (same name: the project's kept)."""
    pieces = list(pieces_of(project))
    materials = {f.name: f for f in project.materials}
    for f in other.materials:
        if f.name in materials and materials[f.name].material != f.material \
                and any(p.settings.material.name == f.name for p in pieces_of(other)):
            raise SettingsError(f"the material {f.name!r} of {other.name!r} differs from the project's of that "
                                f"name: rename one first")
        materials.setdefault(f.name, f)
    rosettes = {r.name.strip().casefold(): r for r in project.rosettes}
    for r in other.rosettes:
        rosettes.setdefault(r.name.strip().casefold(), r)
    first = len(pieces)
    names = {}
    for p in pieces_of(other):
        names[p.name] = free_name((q.name for q in pieces), p.name)
        pieces.append(replace(p, name=names[p.name]))
    sewings = list(project.sewings)  # other's shapes split by seams come too, naming its pieces as renamed
    for s in _sewings_renamed(other.sewings, names):
        sewings.append(replace(s, name=free_name((t.name for t in sewings), s.name)))
    out = replace(project, materials=tuple(materials.values()), rosettes=tuple(rosettes.values()))
    return with_pieces(out, pieces, first if select_it else project.piece_index, sewings)


def resurface(project, old, new, source: str | None = None):
    """The project with every piece on surface ``old`` moved to ``new`` (a refit of the same
    (u, v) map: regions, seeds and drawings stay), from ``source`` (default each piece's own)."""
    pieces = tuple(replace(p, surface=new, source=p.source if source is None else source)
                   if p.surface is old else p for p in pieces_of(project))
    sewings = tuple(replace(s, surface=new, source=s.source if source is None else source)
                    if s.surface is old else s for s in project.sewings)
    return with_pieces(replace(project, surface=pieces[project.piece_index].surface, sewings=()), pieces,
                       project.piece_index, sewings)


def duplicate(project, k, name: str | None = None, angle_deg: float | None = None):
    """The project with a copy of piece ``k`` right after it (selected), unsolved,
    at ``angle_deg`` if given, so a ply is repeated at another orientation: its
    orientation from its rosette when it has one, else its weft angle. Named
    ``name`` (default the original's with the angle, or "copy")."""
    i = index_of(project, k)
    pieces = pieces_of(project)
    src = pieces[i]
    copy = replace(src, result=None)
    if angle_deg is not None:
        if isinstance(angle_deg, bool) or not isinstance(angle_deg, (int, float)) or not math.isfinite(angle_deg):
            raise SettingsError(f"a piece's orientation must be a finite angle in degrees, got {angle_deg!r:.40}")
        if src.rosette is None:
            copy = replace(copy, settings=replace(src.settings, angle_deg=float(angle_deg)))
        else:
            copy = _oriented(project, replace(copy, orientation=float(angle_deg)))
    if name is None:  # named after the original, its own angle label (if it has one) replaced by the new angle
        base = src.name
        label = f" {src.settings.angle_deg if src.rosette is None else src.orientation:+g}"
        if angle_deg is not None and base.endswith(label) and len(base) > len(label):
            base = base[:-len(label)]
        name = free_name((q.name for q in pieces),
                         f"{base} {angle_deg:+g}" if angle_deg is not None else f"{base} copy")
    copy = replace(copy, name=name)
    return with_pieces(project, pieces[:i + 1] + (copy,) + pieces[i + 1:], i + 1)


def remove(project, k):
    """The project without piece ``k``; its neighbour (the next, or the last) active if it was."""
    i = index_of(project, k)
    pieces = pieces_of(project)
    if len(pieces) == 1:
        raise SettingsError("a project keeps at least one piece: this is its only one")
    new = pieces[:i] + pieces[i + 1:]
    active = project.piece_index
    active = min(i, len(new) - 1) if active == i else active - (active > i)
    out = with_pieces(project, new, active, _sewings_renamed(project.sewings, {pieces[i].name: None}))
    return replace(out, cut_plan=project.cut_plan.renamed({pieces[i].name: None}))


def _changed(project, k, change, sewings=None):
    """The project with piece ``k`` replaced by ``change(piece)``; the list is checked as the
    project is made (distinct names, sane counts)."""
    i = index_of(project, k)
    pieces = pieces_of(project)
    return with_pieces(project, pieces[:i] + (change(pieces[i]),) + pieces[i + 1:], project.piece_index, sewings)


def rename(project, k, name: str):
    """The project with piece ``k`` named ``name`` (distinct from the others; a panel's shape names it anew,
    and its splices and mirror pairing in the cut plan go with it)."""
    old = pieces_of(project)[index_of(project, k)].name
    out = _changed(project, k, lambda p: replace(p, name=name), _sewings_renamed(project.sewings, {old: name}))
    return replace(out, cut_plan=project.cut_plan.renamed({old: name}))


def move(project, k, to: int):
    """The project with piece ``k`` moved to position ``to`` (the others keep their order)."""
    i = index_of(project, k)
    pieces = list(pieces_of(project))
    if isinstance(to, bool) or not isinstance(to, int) or not 0 <= to < len(pieces):
        raise SettingsError(f"no position {to!r}: the project has {len(pieces)} pieces")
    active = pieces[project.piece_index]
    p = pieces.pop(i)
    pieces.insert(to, p)
    return with_pieces(project, pieces, next(j for j, q in enumerate(pieces) if q is active))


def set_quantity(project, k, quantity: int):
    """The project with ``quantity`` copies of piece ``k`` to cut."""
    return _changed(project, k, lambda p: replace(p, quantity=quantity))


def set_sequence(project, k, sequence: int | None):
    """The project with piece ``k`` at ``sequence`` in the laminate's stack (None: outside one)."""
    return _changed(project, k, lambda p: replace(p, sequence=sequence))


def use_material(project, k, name: str):
    """The project with piece ``k`` cut from the table's material ``name`` (its mechanics and shear
    angles become the piece's; a solved piece's result goes stale if they differ)."""
    fabric = project.fabric(name)
    if fabric is None:
        raise SettingsError(f"no material is named {name!r} in the table "
                            f"({', '.join(f.name for f in project.materials)[:200]})")
    return _changed(project, k, lambda p: replace(p, settings=replace(p.settings, material=fabric.material)))


def set_materials(project, fabrics):
    """The project with the materials table ``fabrics``: every piece cut from a material of that
    name takes the row's mechanics and shear angles (a row edited re-judges, or re-solves, its pieces)."""
    fabrics = tuple(fabrics)
    by_name = {f.name: f for f in fabrics}
    pieces = tuple(replace(p, settings=replace(p.settings, material=by_name[p.settings.material.name].material))
                   if p.settings.material.name in by_name and by_name[p.settings.material.name].material
                   != p.settings.material else p for p in pieces_of(project))
    return with_pieces(replace(project, materials=fabrics), pieces, project.piece_index)


# ---------------------------------------------------------------------- rosettes
def _oriented(project, piece, rosettes=None) -> Piece:
    """``piece`` with the weft angle its orientation from its rosette gives at its seed
    (unchanged, the same object, when it has no rosette or the angle is already that)."""
    if piece.rosette is None:
        return piece
    surface = project.surface if piece.surface is None else piece.surface
    angle = piece_weft(surface, project.rosettes if rosettes is None else rosettes, piece)
    if angle == piece.settings.angle_deg:
        return piece
    return replace(piece, settings=replace(piece.settings, angle_deg=angle))


def orient(project, k, rosette: str | None, orientation: float | None = None):
    """The project with piece ``k`` oriented ``orientation`` degrees from the tool rosette
    named ``rosette`` (its weft angle set to match at its seed). ``orientation`` None: the
    piece keeps its fibres and the orientation is read from its weft angle. ``rosette``
    None: the piece no longer follows a rosette (its weft angle stays)."""
    i = index_of(project, k)
    piece = pieces_of(project)[i]
    if rosette is None:
        return _changed(project, i, lambda p: replace(p, rosette=None, orientation=None))
    r = rosette_named(project.rosettes, rosette)
    if orientation is None:
        orientation = orientation_for(piece.surface, piece.settings.seed, r.zero, piece.settings.angle_deg)
        if orientation is None:
            raise SettingsError(f"rosette {r.name!r}'s 0-degree direction is along the surface's normal at "
                                f"{piece.name!r}'s seed: it sets no direction there")
        orientation = round(orientation, 9)  # a whole angle read back stays whole (45, not 44.99999999999999)
    return _changed(project, i, lambda p: _oriented(project, replace(p, rosette=r.name, orientation=orientation)))


def set_rosettes(project, rosettes):
    """The project with the rosette table ``rosettes`` (ToolRosettes, distinct names); every
    piece oriented from one takes the weft angle its orientation gives from the new
    table's rosette of that name. A rosette a piece is oriented from cannot go (one line)."""
    rosettes = tuple(rosettes)
    pieces = pieces_of(project)
    check_rosettes(rosettes, pieces)
    pieces = tuple(_oriented(project, p, rosettes) for p in pieces)
    return with_pieces(replace(project, rosettes=rosettes), pieces, project.piece_index)


def follow_rosettes(before, after):
    """``after`` (an edit of ``before``) with its pieces' orientations and weft angles agreeing.

    The active piece's weft angle set directly (it changed while its rosette and orientation did
    not) turns its orientation; otherwise a piece oriented from a rosette takes the weft angle its
    orientation gives at its seed (its seed moved, the surface or a rosette changed, an orientation
    was set). Only the active piece is looked at unless the surface or the rosette table changed."""
    if not after.rosettes:
        return after
    every = after.surface is not before.surface or after.rosettes != before.rosettes
    given = pieces_of(after)
    pieces = list(given)
    i = after.piece_index
    p = pieces[i]
    if p.rosette is not None and before.piece_name == p.name and before.piece_rosette == p.rosette \
            and before.orientation == p.orientation and before.settings.angle_deg != p.settings.angle_deg \
            and not every:
        return orient(after, i, p.rosette, None)
    for j in (range(len(pieces)) if every else (i,)):
        pieces[j] = _oriented(after, pieces[j])
    if all(a is b for a, b in zip(pieces, given)):
        return after
    return with_pieces(after, pieces, i)
