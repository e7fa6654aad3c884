"""Export a flattened result: the pattern for cutters, printers and pattern
makers (DXF, SVG, tiled 1:1 PDF) and the 3D result for other tools (VTP, OBJ,
the fibre angles as CSV).

    from flatweave.export.registry import ExportOptions, export
    export(result, "octant.dxf", ExportOptions(seam_allowance_mm=10, units="m"))

The file's suffix picks the format. A format is one :func:`register_exporter`
call (the built-in ones are at the end of this module), which also declares the
options its writer reads (:class:`ExportOption`: name, kind, choices, default,
help); :data:`FORMATS`, :func:`dialog_filter`, the CLI's flags and help and the
export dialog's rows are all read from that registry.

Every writer builds the whole file in memory and it is written atomically, so
a failed export leaves no partial file and an existing file untouched (a full disk, a folder that
refuses the file: a one-line FlatweaveError naming the file and the reason).
:func:`export_all` is all or nothing: it checks every target, builds every
file, writes each to a temporary file and renames them only when all are
written. Check targets with :func:`check_target` before a long solve, and
ask :func:`surprises` what an export would do that its user may not expect
(hundreds of pages, a piece metres across: often a model's units taken
wrongly) before writing it.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from typing import Any
from pathlib import Path

import numpy as np

from flatweave.errors import SettingsError
from flatweave.export.dxf import VARIANTS as DXF_VARIANTS
from flatweave.export.mesh3d import OBJ_TEXTURES
from flatweave.export.pdf import PAPERS, page_count
from flatweave.export.sheet import UNITS, Sheet, build_sheet, mm_per_unit
from flatweave.files import atomic_write_many, check_output
from flatweave.export.dxf import dxf_bytes
from flatweave.export.svg import svg_text
from flatweave.export.pdf import pdf_bytes
from flatweave.export.mesh3d import vtp_surface_text
from flatweave.export.mesh3d import vtp_files
from flatweave.method.fibres import fibres_csv
from flatweave.export.mesh3d import obj_files

__all__ = ["MAX_SEAM_MM", "ExportOptions", "ExportOption", "export_options", "option_formats", "Exporter", "FORMATS",
           "UNITS",
           "PAPERS", "DXF_VARIANTS", "OBJ_TEXTURES",
           "export", "export_all", "export_bytes", "export_files",
           "check_target", "register_exporter", "unregister_exporter", "exporters", "exporter_for",
           "dialog_filter", "build_sheet", "Sheet", "mm_per_unit", "Surprise", "surprises", "MAX_QUIET_PAGES",
           "MAX_QUIET_PIECE_MM"]

MAX_QUIET_PAGES = 50  # a PDF of more pages is a surprise
MAX_QUIET_PIECE_MM = 5000.0  # so is a 2D file with a piece larger than this (its longer side, cut line)


@dataclass(frozen=True)
class ExportOption:
    """One option an exporter's writer reads, declared with the exporter: the
    CLI's flag and the export dialog's row are built from it.

    name : the key in :class:`ExportOptions` (``options.get(name)``)
    kind : ``"number"``, ``"choice"`` or ``"text"``
    default : the value when not given
    help : one line, for the CLI's help and the dialog's tooltip
    label : the dialog's row label
    choices : for ``"choice"``: value -> the text the dialog shows
    flag : the CLI's flag (default: ``--`` and the name with dashes)
    unit : shown after a number (``"mm"``)
    minimum, maximum : a number's range
    """

    name: str
    kind: str
    default: Any
    help: str
    label: str
    choices: Mapping[str, str] | None = None
    flag: str = ""
    unit: str = ""
    minimum: float = 0.0
    maximum: float = math.inf

    def __post_init__(self):
        if self.kind not in ("number", "choice", "text"):
            raise ValueError(f"option kind {self.kind!r} is not number, choice or text")
        if self.kind == "choice" and not self.choices:
            raise ValueError(f"option {self.name!r} is a choice with no choices")

    @property
    def what(self) -> str:
        """How a message names it: the label without its parenthesis, acronyms kept."""
        words = self.label.split(" (")[0]
        return words if words[:2].isupper() else words.lower()

    @property
    def cli_flag(self) -> str:
        return self.flag or "--" + self.name.replace("_", "-")

    def check(self, value: Any) -> Any:
        """The value as the writer gets it, or a one-line SettingsError naming the option."""
        if self.kind == "number":
            try:
                x = float(value)
            except (TypeError, ValueError):
                x = math.nan
            if not (self.minimum <= x <= self.maximum) or math.isinf(x):
                unit = f" {self.unit}" if self.unit else ""
                bound = f"from {self.minimum:g} to {self.maximum:g}" if math.isfinite(self.maximum) \
                    else f"of at least {self.minimum:g}"
                raise SettingsError(f"{self.what} {value!r}{unit} must be a number {bound}")
            return x
        if self.kind == "choice":
            key = str(value).lower() if isinstance(value, str) else value
            if key not in self.choices:
                raise SettingsError(f"unknown {self.what} {value!r}: use one of {', '.join(self.choices)}")
            return key
        return str(value)


@dataclass(frozen=True)
class Exporter:
    """One registered export format.

    suffix : lower-case file suffix with the dot, e.g. ``".dxf"``
    writer : ``writer(result, options, sheet) -> bytes``; ``sheet`` is the 2D
        :class:`Sheet` when ``needs_sheet``, else None
    description : what the file holds, for dialogs and help
    needs_sheet : True for 2D pattern formats (the sheet is built once per export)
    companions : optional ``companions(result, options, sheet, path) -> [(path, bytes), ...]``:
        files written beside ``path`` with it (all or nothing, like the main file),
        e.g. the OBJ's ``.mtl`` and texture; when given, the main file is
        ``companions``' first entry and ``writer`` serves :func:`export_bytes`
    options : the :class:`ExportOption` s the writer reads
    """

    suffix: str
    writer: Callable[..., bytes]
    description: str
    needs_sheet: bool
    companions: Callable[..., list] | None = None
    options: tuple[ExportOption, ...] = ()

    def files(self, result, options, sheet, path: Path) -> list[tuple[Path, bytes]]:
        """Every file an export to ``path`` writes, the main one first."""
        if self.companions is not None:
            return [(Path(p), data) for p, data in self.companions(result, options, sheet, path)]
        return [(path, self.writer(result, options, sheet))]


_EXPORTERS: dict[str, Exporter] = {}


def register_exporter(suffix: str, writer: Callable[..., bytes], description: str, needs_sheet: bool,
                      companions: Callable[..., list] | None = None, options=()) -> Exporter:
    """Add the format of files ending in ``suffix``; returns its entry (see :class:`Exporter`).

    ValueError if the suffix is malformed or already has an exporter, or if an
    option shares a name with another format's option but not its declaration.
    """
    s = str(suffix).lower()
    if not s.startswith(".") or len(s) < 2 or "/" in s or os.sep in s:
        raise ValueError(f"a suffix is a dot and a name, like '.dxf', not {suffix!r}")
    if s in _EXPORTERS:
        raise ValueError(f"{s} files already have an exporter")
    options = tuple(options)
    known = {o.name: o for o in export_options()}
    for o in options:
        if not isinstance(o, ExportOption):
            raise ValueError(f"an exporter's options are ExportOption declarations, not {type(o).__name__}")
        if o.name in known and known[o.name] != o:
            raise ValueError(f"option {o.name!r} is declared differently by another format")
    entry = Exporter(s, writer, str(description), bool(needs_sheet), companions, options)
    _EXPORTERS[s] = entry
    return entry


def unregister_exporter(suffix: str) -> None:
    """Remove the exporter of ``suffix`` (KeyError if there is none)."""
    del _EXPORTERS[str(suffix).lower()]


def exporters() -> list[Exporter]:
    """The registered exporters, in registration order."""
    return list(_EXPORTERS.values())


def export_options() -> list[ExportOption]:
    """Every option some registered format reads, once each, in registration order."""
    seen: dict[str, ExportOption] = {}
    for e in _EXPORTERS.values():
        for o in e.options:
            seen.setdefault(o.name, o)
    return list(seen.values())


def option_formats(name: str) -> list[str]:
    """The suffixes of the formats that read option ``name``."""
    return [e.suffix for e in _EXPORTERS.values() if any(o.name == name for o in e.options)]


def exporter_for(suffix: str) -> Exporter | None:
    """The exporter of ``suffix`` (case-insensitive), or None."""
    return _EXPORTERS.get(str(suffix).lower())


class _Formats(Mapping):
    """Read-only view of the registry: suffix -> description, in registration order."""

    def __getitem__(self, suffix: str) -> str:
        return _EXPORTERS[suffix].description

    def __iter__(self):
        return iter(list(_EXPORTERS))

    def __len__(self) -> int:
        return len(_EXPORTERS)

    def __repr__(self) -> str:
        return f"FORMATS({dict(self)!r})"


FORMATS: Mapping[str, str] = _Formats()
"""Every export format: suffix -> description (a live view of the registry)."""


def dialog_filter() -> str:
    """A Qt file-dialog filter with one entry per format, e.g. ``"DXF ... (*.dxf);;SVG ... (*.svg)"``."""
    return ";;".join(f"{e.description} (*{e.suffix})" for e in _EXPORTERS.values())


def _needs_sheet(suffixes) -> bool:
    return any(e is not None and e.needs_sheet for e in map(exporter_for, suffixes))


@dataclass(frozen=True)
class ExportOptions:
    """How a pattern is exported: a value for each option the formats declare
    (:func:`export_options`); a writer reads ``options.get(name)``.

    seam_allowance_mm : width of the seam allowance (0: none)
    units : the model's units (mm, cm, m, in); 2D files are written in mm
    paper : a4 or letter, for the PDF
    name : the piece's name in labels and DXF blocks
    dxf_variant : ``"astm"`` (ASTM D6673 / AAMA, R12, for pattern CAD and cutting rooms)
        or ``"layered"`` (AutoCAD R2000 with the same layers and ``$INSUNITS``, for CAD,
        GDAL, laser and knife cutters); see :mod:`flatweave.export.dxf`
    obj_texture : ``"none"`` (texture coordinates = the pattern's ``nodes.xy``) or
        ``"checker"`` (also a ``.mtl`` and a checker PNG beside the OBJ, the texture
        coordinates scaled so the checker squares are round lengths of the pattern)
    extra : the values of options other formats declare (a registered exporter's own)

    Every value is checked against its declaration when made: a one-line SettingsError.
    """

    seam_allowance_mm: float = 10.0
    units: str = "m"
    paper: str = "a4"
    name: str = "piece"
    dxf_variant: str = "astm"
    obj_texture: str = "none"
    extra: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        declared = {o.name: o for o in export_options()}
        for f in fields(self):
            if f.name != "extra" and f.name in declared:
                object.__setattr__(self, f.name, declared[f.name].check(getattr(self, f.name)))
        extra = dict(self.extra)
        for key, value in extra.items():
            if key not in declared:
                raise SettingsError(f"no export format has an option {key!r}")
            extra[key] = declared[key].check(value)
        object.__setattr__(self, "extra", extra)

    @classmethod
    def from_values(cls, values: Mapping[str, Any]) -> "ExportOptions":
        """Options from name -> value (the CLI's flags, the dialog's rows); unnamed ones keep their defaults."""
        own = {f.name for f in fields(cls)} - {"extra"}
        return cls(**{k: v for k, v in values.items() if k in own},
                   extra={k: v for k, v in values.items() if k not in own})

    def get(self, name: str) -> Any:
        """The value of option ``name``: given, or its declared default."""
        if name in self.extra:
            return self.extra[name]
        if name != "extra" and name in {f.name for f in fields(self)}:
            return getattr(self, name)
        for o in export_options():
            if o.name == name:
                return o.default
        raise KeyError(name)


def check_target(path) -> Path:
    """The path, if its suffix names a format and its folder is writable; else a one-line error."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in FORMATS:
        raise SettingsError(f"cannot export {path}: unknown format {suffix or '(no suffix)'!r}; "
                            f"use one of {', '.join(FORMATS)}")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        what = "is not a folder" if folder.exists() else "does not exist"
        raise SettingsError(f"cannot export {path}: {folder} {what}")
    if not os.access(folder, os.W_OK):
        raise SettingsError(f"cannot export {path}: folder {folder} is not writable")
    if path.is_dir():
        raise SettingsError(f"cannot export {path}: it is a folder")
    check_output(path, SettingsError)  # a device or a pipe there is never replaced
    return path


def export_bytes(result, suffix: str, options: ExportOptions = ExportOptions(), sheet: Sheet | None = None) -> bytes:
    """The file's contents for a format suffix (``.dxf``, ``.svg``, ...)."""
    entry = exporter_for(suffix)
    if entry is None:
        raise SettingsError(f"unknown export format {suffix.lower()!r}; use one of {', '.join(FORMATS)}")
    if not entry.needs_sheet:
        return entry.writer(result, options, None)
    if sheet is None:
        sheet = build_sheet(result, options.units, options.seam_allowance_mm, options.name)
    return entry.writer(result, options, sheet)


def export(result, path, options: ExportOptions = ExportOptions(), sheet: Sheet | None = None) -> Path:
    """Write ``result`` to ``path`` in the format its suffix names; returns the path."""
    path = check_target(path)
    atomic_write_many(_files(result, path, options, sheet))
    return path


def export_all(result, paths, options: ExportOptions = ExportOptions(), sheet=None) -> list[Path]:
    """Write several formats, building the 2D sheet once (or drawing ``sheet``, built by the caller: a
    panel's, with its seams' notches and allowances); returns the paths.

    All or nothing: every target is checked and every file built before any is
    written, and the files are renamed into place only when all of them are on
    disk, so a failure (a bad target, a full disk) leaves every target as it
    was (see :func:`flatweave.files.atomic_write_many` for a failed rename).
    """
    paths = [check_target(p) for p in paths]
    atomic_write_many(export_files(result, paths, options, sheet))
    return paths


def export_files(result, paths, options: ExportOptions = ExportOptions(), sheet=None) -> list[tuple[Path, bytes]]:
    """Every file exporting ``result`` to ``paths`` writes, as (path, bytes), nothing written: for a
    caller that writes them with its own files, all or nothing (the command's ``--out`` and
    ``--export``). The 2D sheet is built once (``sheet``: the caller's)."""
    paths = [check_target(p) for p in paths]
    if sheet is None and _needs_sheet(p.suffix for p in paths):
        sheet = build_sheet(result, options.units, options.seam_allowance_mm, options.name)
    return [f for p in paths for f in _files(result, p, options, sheet)]


@dataclass(frozen=True)
class Surprise:
    """Something an export would do that its user may not expect.

    files : the targets it concerns
    text : one sentence, capitalised, without a full stop, e.g. ``"The PDF will have 8,182
        pages at 1:1 on A4 (the piece is 53.2 x 15.1 m, units m)"``
    """

    files: tuple
    text: str

    def line(self) -> str:
        """The files' names and the text on one line: ``"p.pdf: the PDF will have ..."``."""
        return f"{', '.join(Path(f).name for f in self.files)}: {self.text[:1].lower()}{self.text[1:]}"


def _metres(mm: float) -> str:
    m = mm / 1000.0
    return f"{m:.0f}" if m >= 100 else f"{m:.1f}" if m >= 10 else f"{m:.2f}"


def surprises(result, paths, options: ExportOptions = ExportOptions(), sheet: Sheet | None = None) -> list[Surprise]:
    """What writing ``result`` to ``paths`` with ``options`` would do that its user may
    not expect, to warn of or ask about before writing; empty when nothing would surprise.

    * a PDF of more than ``MAX_QUIET_PAGES`` pages (counted by :func:`flatweave.export.pdf.page_count`,
      the tiling the writer uses; nothing is drawn): one :class:`Surprise` naming the page
      count, the paper, the largest piece's size and the model's units;
    * a piece larger than ``MAX_QUIET_PIECE_MM`` (its cut line's longer side) in the other
      2D files (drawn at 1:1 in mm): one naming its size and the units.

    3D files (model units, nothing scaled) and unknown suffixes never surprise. The 2D
    sheet is built from ``options`` unless given.
    """
    flat = [Path(p) for p in paths if (e := exporter_for(Path(p).suffix)) is not None and e.needs_sheet]
    if not flat:
        return []
    if sheet is None:
        sheet = build_sheet(result, options.units, options.seam_allowance_mm, options.name)
    sizes = [tuple(float(d) for d in np.ptp(p.bounds(), axis=0)) for p in sheet.pieces]
    w, h = max(sizes, key=max)
    one = len(sizes) == 1
    piece = f"the piece is {_metres(w)} x {_metres(h)} m" if one else \
        f"the largest of {len(sizes)} pieces is {_metres(w)} x {_metres(h)} m"
    out = []
    pdfs = [p for p in flat if p.suffix.lower() == ".pdf"]
    if pdfs:
        pages = page_count(sheet, options.paper)
        if pages > MAX_QUIET_PAGES:
            paper = {"a4": "A4", "letter": "US Letter"}.get(options.paper.lower(), options.paper)
            out.append(Surprise(tuple(pdfs), f"The PDF will have {pages:,} pages at 1:1 on {paper} "
                                             f"({piece}, units {options.units})"))
    rest = [p for p in flat if not (out and p in out[0].files)]
    if rest and max(w, h) > MAX_QUIET_PIECE_MM:
        out.append(Surprise(tuple(rest), f"{piece[:1].upper()}{piece[1:]} at 1:1 (units {options.units})"))
    return out


def _files(result, path: Path, options: ExportOptions, sheet: Sheet | None) -> list[tuple[Path, bytes]]:
    entry = exporter_for(path.suffix)
    if entry is None:
        raise SettingsError(f"unknown export format {path.suffix.lower()!r}; use one of {', '.join(FORMATS)}")
    if entry.needs_sheet and sheet is None:
        sheet = build_sheet(result, options.units, options.seam_allowance_mm, options.name)
    return entry.files(result, options, sheet if entry.needs_sheet else None, path)


# ---------------------------------------------------------------------- the formats
# The writers import their libraries (ezdxf, reportlab) only when a file is written.
def _dxf(result, options: ExportOptions, sheet: Sheet) -> bytes:
    return dxf_bytes(sheet, options.dxf_variant)


def _svg(result, options: ExportOptions, sheet: Sheet) -> bytes:
    return svg_text(sheet).encode("utf-8")


def _pdf(result, options: ExportOptions, sheet: Sheet) -> bytes:
    return pdf_bytes(sheet, options.paper, title=options.name)


def _vtp(result, options: ExportOptions, sheet: None) -> bytes:
    return vtp_surface_text(result).encode("ascii")


def _vtp_files(result, options: ExportOptions, sheet: None, path: Path) -> list:
    return vtp_files(result, path)


def _csv(result, options: ExportOptions, sheet: None) -> bytes:
    return fibres_csv(result).encode("ascii")


def _obj(result, options: ExportOptions, sheet: None) -> bytes:
    return obj_files(result, Path(f"{options.name}.obj"), options.name, options.obj_texture)[0][1]


def _obj_files(result, options: ExportOptions, sheet: None, path: Path) -> list:
    return obj_files(result, path, options.name, options.obj_texture)


MAX_SEAM_MM = 500.0  # a seam allowance past half a metre is a slip of the units, not a seam
SEAM_ALLOWANCE = ExportOption("seam_allowance_mm", "number", 10.0, "seam allowance of exported patterns in mm "
                              "(0 for none)", "Seam allowance", flag="--seam-allowance", unit="mm",
                              maximum=MAX_SEAM_MM)
MODEL_UNITS = ExportOption("units", "choice", "m", "units of the surface model (what one coordinate unit is); 2D "
                           "files are written in mm", "Model units", choices={u: u for u in UNITS})
PIECE_NAME = ExportOption("name", "text", "piece", "piece name in exported labels and DXF blocks", "Piece name")
PAPER = ExportOption("paper", "choice", "a4", "paper of the tiled PDF", "Paper (PDF)",
                     choices={p: (p.upper() if p == "a4" else p) for p in PAPERS})
DXF_VARIANT = ExportOption("dxf_variant", "choice", "astm", "DXF for pattern CAD and cutting rooms (astm: ASTM "
                           "D6673 / AAMA, R12) or for CAD, GDAL and laser cutters (layered: R2000 with $INSUNITS)",
                           "DXF variant", choices=dict(DXF_VARIANTS))
OBJ_TEXTURE = ExportOption("obj_texture", "choice", "none", "checker: an OBJ export also writes a .mtl and a checker "
                           "texture", "OBJ texture",
                           choices={"none": "none (the pattern as texture coordinates)",
                                    "checker": "checker (.mtl and image: the pattern shows on the surface)"})

register_exporter(".dxf", _dxf, "DXF, ASTM D6673 / AAMA (R12) or layered R2000, mm", needs_sheet=True,
                  options=(SEAM_ALLOWANCE, MODEL_UNITS, PIECE_NAME, DXF_VARIANT))
register_exporter(".svg", _svg, "SVG at true size (mm)", needs_sheet=True,
                  options=(SEAM_ALLOWANCE, MODEL_UNITS, PIECE_NAME))
register_exporter(".pdf", _pdf, "PDF, tiled 1:1 with overview and assembly map", needs_sheet=True,
                  options=(SEAM_ALLOWANCE, MODEL_UNITS, PIECE_NAME, PAPER))
register_exporter(".vtp", _vtp, "VTK PolyData: draped mesh and cell shear, springs and their strain beside it",
                  needs_sheet=False, companions=_vtp_files)
register_exporter(".obj", _obj, "Wavefront OBJ: surface mesh, pattern as texture coordinates",
                  needs_sheet=False, companions=_obj_files, options=(PIECE_NAME, OBJ_TEXTURE))
register_exporter(".csv", _csv, "CSV of fibre angles per cell: centre, (u, v), weft and warp directions, "
                  "deviation from the rosette, shear", needs_sheet=False)
