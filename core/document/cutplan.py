"""The cut plan (issue 43): a project's solved pieces (or a result file's pattern pieces) turned into
the items a marker nests (:mod:`flatweave.studies.nesting`), one marker per material.

Each pattern piece of a current result becomes an item: its cut outline as its cut
files draw it (:func:`flatweave.document.sewing.piece_sheet`: the seam allowance,
a panel's own per seam), in millimetres in the frame of its ``pattern.pieces[k].outline``,
its quantity (the piece's, times the copies asked), its grain (the sheet's grain line:
the warp) and the rotations its material allows (a woven fabric keeps its grain: 0 or
180 degrees; an isotropic sheet any; ``rotations`` overrides). Pieces cut from
different materials go on different markers, each on its material's roll.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flatweave.document.plybook import book_order
from flatweave.document.project import settings_equal
from flatweave.document.sewing import piece_sheet
from flatweave.errors import SettingsError
from flatweave.export.marker import MarkerSource
from flatweave.export.sheet import SheetPiece, build_sheet
from flatweave.method.materials import fabric_kind
from flatweave.studies.nesting import ROTATIONS, NestItem

__all__ = ["PlanItem", "project_items", "result_items", "instance_items", "by_material", "rotations_for",
           "check_rotations", "source_name"]


@dataclass(frozen=True)
class PlanItem:
    """An item to nest, where it came from, and the material it is cut from (its marker)."""

    item: NestItem
    source: MarkerSource
    material: str


def rotations_for(material) -> str:
    """The rotations a piece of ``material`` (a :class:`flatweave.method.lattice.Material`) may take on the
    roll: "grain" for a woven fabric (its threads along and across the roll), "free" for an isotropic sheet,
    "grain" for anything else (a custom lattice keeps its directions)."""
    return "free" if fabric_kind(material) == "isotropic" else "grain"


def _grain_deg(sheet_piece) -> float:
    """The direction of the sheet piece's grain line (its warp), degrees from +x."""
    d = np.asarray(sheet_piece.grain[1], dtype=float) - np.asarray(sheet_piece.grain[0], dtype=float)
    return math.degrees(math.atan2(d[1], d[0])) if np.hypot(*d) > 0 else 90.0


def _items(sheet, name: str, source: str, quantity: int, material, rotations: str | None) -> list[PlanItem]:
    out = []
    many = len(sheet.pieces) > 1
    for k, sp in enumerate(sheet.pieces):
        outline = np.asarray(sp.outer, dtype=float) - np.asarray(sp.offset, dtype=float)
        item = NestItem(f"{name} {k + 1}" if many else name, outline, quantity, _grain_deg(sp),
                        rotations or rotations_for(material))
        out.append(PlanItem(item, MarkerSource(source, k, sp), material.name))
    return out


def result_items(result, name: str, source: str, units: str, seam_allowance_mm: float, copies: int = 1,
                 rotations: str | None = None) -> list[PlanItem]:
    """The items of a result's pattern pieces (``copies`` each), named ``name`` (numbered when several),
    ``source`` the input's name, the model in ``units``."""
    _check_copies(copies)
    sheet = build_sheet(result, units, seam_allowance_mm, name, copies)
    return _items(sheet, name, source, copies, result.settings.material, rotations)


def project_items(project, source: str, seam_allowance_mm: float, copies: int = 1,
                  rotations: str | None = None) -> tuple[list[PlanItem], list[str]]:
    """The items of every solved piece of ``project`` (each its quantity times ``copies``), in laying
    order, and the names of the pieces left out (not solved, or solved before their last change)."""
    _check_copies(copies)
    out, left = [], []
    for p in book_order(project):
        r = p.result
        if r is None or not settings_equal(r.settings, p.settings) or not r.pattern.pieces:
            left.append(p.name)
            continue
        sheet = piece_sheet(project, p.name, seam_allowance_mm)
        out += _items(sheet, p.name, f"{source}#{p.name}", p.quantity * copies, p.settings.material, rotations)
    return out, left


def instance_items(doc: dict, source: str, copies: int = 1, rotations: str | None = None) -> list[PlanItem]:
    """The items of a nesting instance (sparrow's and ESICUP's JSON: ``items``, each with ``id``, ``demand``,
    ``allowed_orientations`` (null: any) and ``shape.data`` its outline; ``strip_height``), in millimetres,
    each drawn by its outline alone; ``rotations`` overrides the instance's."""
    _check_copies(copies)
    rows = doc.get("items")
    if not isinstance(rows, list) or not rows or len(rows) > 10_000:
        raise SettingsError(f"{source}: a nesting instance's items must be a list of 1 to 10000 items")
    out = []
    for k, row in enumerate(rows):
        try:
            shape = np.asarray(row["shape"]["data"], dtype=float)
            demand = row["demand"]
            turns = row.get("allowed_orientations")
            turns = None if turns is None else tuple(float(a) for a in turns) or (0.0,)
        except (KeyError, TypeError, ValueError):
            raise SettingsError(f"{source}: item {k + 1} needs a shape (shape.data: [[x, y], ...]), a demand and "
                                f"allowed_orientations (a list of degrees, or null)") from None
        if shape.ndim == 2 and len(shape) > 3 and np.array_equal(shape[0], shape[-1]):
            shape = shape[:-1]
        name = f"{source} {row.get('id', k)}"
        try:
            item = NestItem(name, shape, int(demand) * copies if isinstance(demand, int) else demand, 0.0,
                            rotations or ("free" if turns is None else turns))
        except SettingsError as exc:
            raise SettingsError(f"{source}: item {k + 1}: {exc}") from None
        sp = SheetPiece(name, item.outline, None, grain=np.array([[0.0, 0.0], [1.0, 0.0]]))
        out.append(PlanItem(item, MarkerSource(source, k, sp), source))
    return out


def by_material(items) -> dict:
    """The items grouped by material (a marker each), in the order first met."""
    out: dict = {}
    for it in items:
        out.setdefault(it.material, []).append(it)
    return out


def _check_copies(copies) -> None:
    if isinstance(copies, bool) or not isinstance(copies, int) or not 1 <= copies <= 100_000:
        raise SettingsError(f"copies must be a whole number from 1 to 100000, got {copies!r:.40}")


def check_rotations(rotations) -> None:
    """A one-line SettingsError unless ``rotations`` is None or a key of ROTATIONS."""
    if rotations is not None and rotations not in ROTATIONS:
        raise SettingsError(f"rotations must be one of {', '.join(ROTATIONS)}, got {rotations!r:.40}")


def source_name(path) -> str:
    """An input's name in a marker's files: its file name."""
    return Path(path).name
