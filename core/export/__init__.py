"""Export a flattened result: the pattern for cutters, printers and pattern
makers (DXF, SVG, tiled 1:1 PDF) and the 3D result for other tools (VTP, OBJ).

    from core.export import ExportOptions, export
    export(result, "octant.dxf", ExportOptions(seam_allowance_mm=10, units="m"))

The file's suffix picks the format (:data:`FORMATS`). Every writer builds
the whole file in memory and writes it atomically, so a failed export leaves
no partial file and an existing file untouched (a full disk, a folder that
refuses the file: a one-line FlatweaveError naming the file and the reason).
:func:`export_all` is all or nothing: it checks every target, builds every
file, writes each to a temporary file and renames them only when all are
written. Check targets with :func:`check_target` before a long solve.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from core.errors import SettingsError
from core.export.pdf import PAPERS
from core.export.sheet import UNITS, Sheet, build_sheet, mm_per_unit
from core.fileio import atomic_write_bytes, atomic_write_many

__all__ = ["ExportOptions", "FORMATS", "UNITS", "PAPERS", "export", "export_all", "export_bytes", "check_target",
           "build_sheet", "Sheet",
           "mm_per_unit"]

FORMATS = {
    ".dxf": "DXF R2000, AAMA layers, mm",
    ".svg": "SVG at true size (mm)",
    ".pdf": "PDF, tiled 1:1 with overview and assembly map",
    ".vtp": "VTK PolyData: draped mesh, spring strain, cell shear",
    ".obj": "Wavefront OBJ: surface mesh, pattern as texture coordinates",
}


@dataclass(frozen=True)
class ExportOptions:
    """How a pattern is exported.

    seam_allowance_mm : width of the seam allowance (0: none)
    units : the model's units (mm, cm, m, in); 2D files are written in mm
    paper : a4 or letter, for the PDF
    name : the piece's name in labels and DXF blocks
    """

    seam_allowance_mm: float = 10.0
    units: str = "m"
    paper: str = "a4"
    name: str = "piece"

    def __post_init__(self):
        mm_per_unit(self.units)
        if self.paper.lower() not in PAPERS:
            raise SettingsError(f"unknown paper {self.paper!r}: use one of {', '.join(PAPERS)}")
        try:
            sa = float(self.seam_allowance_mm)
        except (TypeError, ValueError):
            sa = float("nan")
        if not sa >= 0 or sa == float("inf"):
            raise SettingsError(f"seam allowance {self.seam_allowance_mm!r} mm must be zero or a positive number")


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
    return path


def export_bytes(result, suffix: str, options: ExportOptions = ExportOptions(), sheet: Sheet | None = None) -> bytes:
    """The file's contents for a format suffix (``.dxf``, ``.svg``, ...)."""
    suffix = suffix.lower()
    if suffix in (".dxf", ".svg", ".pdf") and sheet is None:
        sheet = build_sheet(result, options.units, options.seam_allowance_mm, options.name)
    if suffix == ".dxf":
        from core.export.dxf import dxf_bytes

        return dxf_bytes(sheet)
    if suffix == ".svg":
        from core.export.svg import svg_text

        return svg_text(sheet).encode("utf-8")
    if suffix == ".pdf":
        from core.export.pdf import pdf_bytes

        return pdf_bytes(sheet, options.paper, title=options.name)
    if suffix == ".vtp":
        from core.export.mesh3d import vtp_text

        return vtp_text(result).encode("ascii")
    if suffix == ".obj":
        from core.export.mesh3d import obj_text

        return obj_text(result, options.name).encode("ascii")
    raise SettingsError(f"unknown export format {suffix!r}; use one of {', '.join(FORMATS)}")


def export(result, path, options: ExportOptions = ExportOptions(), sheet: Sheet | None = None) -> Path:
    """Write ``result`` to ``path`` in the format its suffix names; returns the path."""
    path = check_target(path)
    atomic_write_bytes(path, export_bytes(result, path.suffix, options, sheet))
    return path


def export_all(result, paths, options: ExportOptions = ExportOptions()) -> list[Path]:
    """Write several formats, building the 2D sheet once; returns the paths.

    All or nothing: every target is checked and every file built before any is
    written, and the files are renamed into place only when all of them are on
    disk, so a failure (a bad target, a full disk) leaves every target as it
    was (see :func:`core.fileio.atomic_write_many` for a failed rename).
    """
    paths = [check_target(p) for p in paths]
    sheet = None
    if any(p.suffix.lower() in (".dxf", ".svg", ".pdf") for p in paths):
        sheet = build_sheet(result, options.units, options.seam_allowance_mm, options.name)
    atomic_write_many([(p, export_bytes(result, p.suffix, options, sheet)) for p in paths])
    return paths
