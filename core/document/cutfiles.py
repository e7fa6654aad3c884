"""The cut files of all a project's pieces at once (issue 41, item 5), named by
piece: one DXF holding a block per piece (as the ASTM variant already holds
a block per pattern piece of one result), and an SVG, a tiled PDF or any
other registered format per piece. Written all or nothing
(:func:`flatweave.files.atomic_write_many`), after every file was built.

A piece with no current result (not solved, or its settings changed since)
has no cut file: :func:`export_pieces` says which were left out.
"""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

from flatweave.document.plybook import book_order
from flatweave.document.project import settings_equal
from flatweave.errors import SettingsError
from flatweave.export.registry import FORMATS, ExportOptions, exporter_for
from flatweave.document.sewing import piece_sheet
from flatweave.export.sheet import join_sheets
from flatweave.files import atomic_write_many

__all__ = ["CUT_FORMATS", "JOINED", "file_stem", "cut_file_plan", "cut_files", "check_folder", "export_pieces"]

CUT_FORMATS = (".dxf", ".svg", ".pdf")  # what a shop cuts from: the default of export_pieces
JOINED = (".dxf",)  # formats written as one file of every piece (a DXF block each); the others one per piece


def file_stem(name: str) -> str:
    """A file name's stem from a piece's (or project's) name: letters, digits, ``-``, ``_`` and
    ``.`` kept, anything else (spaces too) made ``_``; never empty, never hidden."""
    stem = re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("._") or "piece"
    return stem[:80]


def _solved(project):
    """(solved pieces in laying order, names of the pieces left out)."""
    solved, left = [], []
    for p in book_order(project):
        ok = p.result is not None and settings_equal(p.result.settings, p.settings) and p.result.pattern.pieces
        (solved if ok else left).append(p if ok else p.name)
    return solved, left


def cut_file_plan(project, folder, formats=CUT_FORMATS) -> tuple[list[tuple[Path, list]], list[str]]:
    """What :func:`export_pieces` would write: ([(path, [pieces in it]), ...], names left out).
    A one-line SettingsError for a format that is not registered or when no piece is solved."""
    folder = Path(folder)
    formats = [f.lower() if f.startswith(".") else "." + f.lower() for f in formats]
    for f in formats:
        if f not in FORMATS:
            raise SettingsError(f"unknown export format {f!r}; use one of {', '.join(FORMATS)}")
    solved, left = _solved(project)
    if not solved:
        raise SettingsError("no piece of the project is solved: nothing to export")
    stems: dict[str, str] = {}
    for p in solved:  # piece names differ, their stems may not ("a/b", "a b")
        stem, n = file_stem(p.name), 2
        while stem.casefold() in {s.casefold() for s in stems.values()}:
            stem, n = f"{file_stem(p.name)}_{n}", n + 1
        stems[p.name] = stem
    plan = []
    for f in dict.fromkeys(formats):
        if f in JOINED:
            plan.append((folder / f"{file_stem(project.name)}-pieces{f}", solved))
        else:
            plan.extend((folder / f"{stems[p.name]}{f}", [p]) for p in solved)
    return plan, left


def cut_files(project, folder, formats=CUT_FORMATS, options: ExportOptions = ExportOptions(),
              notch_every_mm: float = 0.0) -> tuple:
    """The cut files of every solved piece, built and not written: ([(path, bytes), ...], names of
    the pieces left out). ``options`` as for one result's export (seam allowance, paper, DXF
    variant); the units are the project's, each file's name its piece's. A panel's seams put
    notches on it (at their ends, the user's, and every ``notch_every_mm`` mm if given) and their
    own seam allowances (:func:`flatweave.document.sewing.piece_sheet`)."""
    plan, left = cut_file_plan(project, folder, formats)
    options = replace(options, units=project.units)
    sheets = {}

    def sheet_of(p):
        if p.name not in sheets:
            sheets[p.name] = piece_sheet(project, p.name, options.seam_allowance_mm, notch_every_mm)
        return sheets[p.name]

    files = []
    for path, pieces in plan:
        entry = exporter_for(path.suffix)
        first = pieces[0]
        mine = replace(options, name=first.name if len(pieces) == 1 else project.name)
        sheet = None
        if entry.needs_sheet:
            sheet = sheet_of(first) if len(pieces) == 1 else join_sheets([sheet_of(p) for p in pieces],
                                                                         project.name)
        files += entry.files(first.result, mine, sheet, path)
    return files, left


def check_folder(folder) -> Path:
    """``folder`` if cut files can go there (a folder, or a name whose parent is one); else one line."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise SettingsError(f"cannot export into {folder}: it is not a folder")
    if not folder.exists() and not folder.parent.is_dir():
        raise SettingsError(f"cannot export into {folder}: folder {folder.parent} does not exist")
    return folder


def export_pieces(project, folder, formats=CUT_FORMATS, options: ExportOptions = ExportOptions(), extra=(),
                  before_replace=None, notch_every_mm: float = 0.0) -> tuple:
    """Write the cut files of every solved piece into ``folder`` (made if missing; its parent must
    exist): (paths written, names of the pieces left out). ``extra``: more (path, bytes) written
    with them (the ply book); ``before_replace()`` runs when every file is staged, before any
    replaces its target (the project's save: if it fails, nothing is written). All or nothing:
    a failure writes no file, and a folder made for them is removed."""
    folder = check_folder(folder)
    files, left = cut_files(project, folder, formats, options, notch_every_mm)
    files += list(extra)
    made = not folder.exists()
    folder.mkdir(exist_ok=True)
    try:
        atomic_write_many(files, before_replace)
    except BaseException:
        if made and not any(folder.iterdir()):  # all or nothing: not even the folder
            folder.rmdir()
        raise
    return [Path(p) for p, _ in files], left
