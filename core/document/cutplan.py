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
from flatweave.export.sheet import SheetPiece, build_sheet, mm_per_unit
from flatweave.method.materials import fabric_kind
from flatweave.geometry.numerics import rotate
from flatweave.method.metrics import cell_shear_deg
from flatweave.studies.nesting import NestItem, min_width, usable_width
from flatweave.studies.splices import check_positions, split_outline, splice_positions

__all__ = ["PlanItem", "SpliceReport", "project_items", "result_items", "instance_items", "by_material",
           "rotations_for", "source_name", "splice_items", "splice_curves"]


@dataclass(frozen=True)
class PlanItem:
    """An item to nest, where it came from, and the material it is cut from (its marker); ``field``:
    its cells' middles (n, 2) mm in its own frame and their shear (n,) degrees, where a splice should
    not go (None: not known)."""

    item: NestItem
    source: MarkerSource
    material: str
    field: tuple | None = None


@dataclass(frozen=True)
class SpliceReport:
    """A piece spliced: its name, its width across the roll (mm), the splices' positions across it (mm,
    in the frame turned ``frame_deg`` from its own, where they run along the roll; ``start`` the piece's
    edge there), its parts' names, whether the user placed them, and the piece's source and pattern
    piece index (as its marker's CSV names them)."""

    name: str
    width: float
    frame_deg: float
    positions: tuple
    parts: tuple
    start: float = 0.0
    asked: bool = False  # the user's splices (else chosen: the piece is wider than the roll)
    source: str = ""  # where the piece came from (its MarkerSource's: "FILE#PIECE" for a project's piece)
    index: int = 0  # the pattern piece's index in its result's pattern.pieces


def rotations_for(material) -> str:
    """The rotations a piece of ``material`` (a :class:`flatweave.method.lattice.Material`) may take on the
    roll: "grain" for a woven fabric (its threads along and across the roll), "free" for an isotropic sheet,
    "grain" for anything else (a custom lattice keeps its directions)."""
    return "free" if fabric_kind(material) == "isotropic" else "grain"


def _grain_deg(sheet_piece) -> float:
    """The direction of the sheet piece's grain line (its warp), degrees from +x."""
    d = np.asarray(sheet_piece.grain[1], dtype=float) - np.asarray(sheet_piece.grain[0], dtype=float)
    return math.degrees(math.atan2(d[1], d[0])) if np.hypot(*d) > 0 else 90.0


def _shear_field(result, mm: float):
    """(cells' middles (c, 2) in the pattern's frame x mm, their shear in degrees (c,))."""
    cells = result.mesh.cells
    middles = np.asarray(result.pattern.xy, dtype=float)[cells].mean(axis=1) * mm
    return middles, cell_shear_deg(result.xyz, result.mesh)


def _items(sheet, name: str, source: str, quantity: int, material, rotations: str | None, field=None,
           mirror: bool = False):
    out = []
    many = len(sheet.pieces) > 1
    for k, sp in enumerate(sheet.pieces):
        outline = np.asarray(sp.outer, dtype=float) - np.asarray(sp.offset, dtype=float)
        item = NestItem(f"{name} {k + 1}" if many else name, outline, quantity, _grain_deg(sp),
                        rotations or rotations_for(material), mirror)
        out.append(PlanItem(item, MarkerSource(source, k, sp), material.name, field))
    return out


def result_items(result, name: str, source: str, units: str, seam_allowance_mm: float, copies: int = 1,
                 rotations: str | None = None, mirror: bool = False) -> list[PlanItem]:
    """The items of a result's pattern pieces (``copies`` each; ``mirror``: in mirror pairs), named ``name``
    (numbered when several), ``source`` the input's name, the model in ``units``."""
    _check_copies(copies)
    sheet = build_sheet(result, units, seam_allowance_mm, name, copies)
    return _items(sheet, name, source, copies, result.settings.material, rotations,
                  _shear_field(result, mm_per_unit(units)), mirror)


def project_items(project, source: str, seam_allowance_mm: float, copies: int = 1,
                  rotations: str | None = None) -> tuple[list[PlanItem], list[str]]:
    """The items of every solved piece of ``project`` (each its quantity times ``copies``, in mirror pairs
    when its cut plan says so), in laying order, and the names of the pieces left out (not solved, or
    solved before their last change)."""
    _check_copies(copies)
    out, left = [], []
    for p in book_order(project):
        r = p.result
        if r is None or not settings_equal(r.settings, p.settings) or not r.pattern.pieces:
            left.append(p.name)
            continue
        sheet = piece_sheet(project, p.name, seam_allowance_mm)
        out += _items(sheet, p.name, f"{source}#{p.name}", p.quantity * copies, p.settings.material, rotations,
                      _shear_field(r, mm_per_unit(project.units)), project.cut_plan.mirrored(p.name))
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


def _frame_deg(item: NestItem) -> float:
    """The angle that turns the item so the lines along the roll run along x: its grain's, or, free to
    turn, the one in which it is narrowest across the roll."""
    if item.turns is not None:
        return item.grain_deg
    angles = np.arange(0.0, 180.0, 0.5)
    widths = [min_width(item.outline, (a,), 0.0) for a in angles]
    return -float(angles[int(np.argmin(widths))])


def splice_items(items, roll_width: float, overlap_mm: float, placed=None) -> tuple[list[PlanItem], list]:
    """``items`` with each one wider than the roll in every rotation it may take split by splices along
    the roll into the fewest parts that fit (:mod:`flatweave.studies.splices`: the parts share
    ``overlap_mm`` at each splice, the splices placed through the least shear), each part an item
    named "NAME part K of N" in the item's own frame; and a report per piece spliced. ``placed``:
    {item name: splice positions, mm across the piece from its edge}, the user's splices, taken as
    given when every part fits (a one-line SettingsError otherwise; a name no item has, too)."""
    usable = usable_width(roll_width)
    placed = dict(placed or {})
    unknown = sorted(set(placed) - {it.item.name for it in items})
    if unknown:
        raise SettingsError(f"no piece to nest is named {unknown[0]!r} (splices are given by piece name)")
    out, reports = [], []
    for it in items:
        item = it.item
        frame = _frame_deg(item)
        if item.name not in placed and min_width(item.outline, item.rotations, item.grain_deg) <= usable:
            out.append(it)
            continue
        # in the frame where the lines along the roll run along x: the outline, its shear field, the splices
        outline = rotate(item.outline, -frame)
        points, shear = (None, None) if it.field is None else (rotate(it.field[0], -frame), it.field[1])
        if item.name in placed:
            positions = check_positions(outline, placed[item.name], usable, overlap_mm, item.name)
        else:
            positions = splice_positions(outline, usable, overlap_mm, points, shear)
        parts = [rotate(q, frame) for q in split_outline(outline, positions, overlap_mm)]
        names = []
        for k, part in enumerate(parts):
            name = f"{item.name} part {k + 1} of {len(parts)}"
            names.append(name)
            mid = part.mean(axis=0)
            d = 0.2 * float(np.ptp(rotate(part, -frame)[:, 0])) * np.array(
                [math.cos(math.radians(item.grain_deg)), math.sin(math.radians(item.grain_deg))])
            sp = SheetPiece(name, part, None, grain=np.array([mid - d, mid + d]))
            out.append(PlanItem(NestItem(name, part, item.quantity, item.grain_deg, item.rotations, item.mirror),
                                MarkerSource(it.source.source, it.source.index, sp), it.material, None))
        reports.append(SpliceReport(item.name, float(np.ptp(outline[:, 1])), frame, tuple(positions), tuple(names),
                                    float(outline[:, 1].min()), item.name in placed, it.source.source,
                                    it.source.index))
    return out, reports


def splice_curves(result, report: SpliceReport, mm: float) -> list[np.ndarray]:
    """Each splice of ``report`` (a piece of ``result``) on the 3D surface: the line along the roll at its
    position, across its pattern piece (``report.index``), mapped from the flat to (u, v) through the
    lattice (each point by the triangle of that piece's nodes it falls in) and onto the surface; (k, 3)
    each."""
    from scipy.spatial import Delaunay

    pieces = result.pattern.pieces
    nodes = np.asarray(pieces[report.index].nodes, dtype=np.int64) if report.index < len(pieces) and len(
        pieces[report.index].nodes) else np.arange(len(result.uv))  # the spliced pattern piece's nodes alone
    xy = np.asarray(result.pattern.xy, dtype=float)[nodes] * mm
    uv_nodes = np.asarray(result.uv, dtype=float)[nodes]
    tri = Delaunay(rotate(xy, -report.frame_deg))
    x0, x1 = tri.points[:, 0].min(), tri.points[:, 0].max()
    out = []
    for s in report.positions:
        line = np.column_stack([np.linspace(x0, x1, 400), np.full(400, s)])
        simplex = tri.find_simplex(line)
        inside = simplex >= 0
        line, simplex = line[inside], simplex[inside]
        t = tri.transform[simplex]
        b = np.einsum("nij,nj->ni", t[:, :2], line - t[:, 2])
        bary = np.column_stack([b, 1.0 - b.sum(axis=1)])
        uv = np.einsum("ni,nic->nc", bary, uv_nodes[tri.simplices[simplex]])
        out.append(result.surface.points(uv))
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


def source_name(path) -> str:
    """An input's name in a marker's files: its file name."""
    return Path(path).name
