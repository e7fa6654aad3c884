"""The readers of files flatweave opens, keyed by file suffix.

Every front end opens a file with :func:`open_path`, so the question "is this
a project or a surface, and which reader parses it?" is answered here once.
A new format is one call::

    register_reader("step", (".step", ".stp"), load_step, "STEP surface")

``load(path)`` gets a :class:`~pathlib.Path` and returns a
:class:`~flatweave.geometry.nurbs.NurbsSurface`, or an :class:`Opened` when it knows more
(the model's units, or a project: readers of projects pass ``project=True`` so
that commands which take only a surface refuse the file before reading it).
It raises a one-line :class:`~flatweave.errors.FlatweaveError` on a bad file.

The CLI's help, its error messages and the window's file dialog
(:func:`dialog_filter`) are all read from the registry.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from flatweave.errors import SettingsError
from flatweave.files import exists
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.reading.opened import Opened
from flatweave.reading.examples import example_info, example_names, example_path
from flatweave.reading.examples import list_examples
from flatweave.document.project import load_project
from flatweave.geometry.surface_json import load_trimmed_surface
from flatweave.reading.cad import read_cad_faces
from flatweave.reading.meshes import MESH_SUFFIXES, open_mesh
from flatweave.reading.jobs import load_job

if TYPE_CHECKING:
    pass

__all__ = ["Reader", "Opened", "register_reader", "unregister_reader", "readers", "reader_for",
           "suffixes", "open_path", "dialog_filter"]


@dataclass(frozen=True)
class Reader:
    """One registered file format.

    name : short name, e.g. ``"geomdl-json"``
    suffixes : lower-case suffixes with the dot, e.g. ``(".json",)``
    load : ``load(path) -> NurbsSurface | Opened``
    description : what the file holds, for dialogs and help (``"geomdl JSON surface"``)
    project : True when the file is a flatweave project (not just a surface)
    """

    name: str
    suffixes: tuple[str, ...]
    load: Callable[[Path], Any]
    description: str
    project: bool = False


_READERS: dict[str, Reader] = {}
_BY_SUFFIX: dict[str, str] = {}


def _suffix(text: str) -> str:
    s = str(text).lower()
    if not s.startswith(".") or len(s) < 2 or os.sep in s or "/" in s:
        raise ValueError(f"a suffix is a dot and a name, like '.json', not {text!r}")
    return s


def register_reader(name: str, suffixes, load: Callable[[Path], Any], description: str, *,
                    project: bool = False) -> Reader:
    """Add a reader for files with any of ``suffixes``; returns its entry.

    ValueError if ``name`` is taken or a suffix already has a reader.
    """
    if isinstance(suffixes, str):
        suffixes = (suffixes,)
    reader = Reader(str(name), tuple(_suffix(s) for s in suffixes), load, str(description), bool(project))
    if not reader.suffixes:
        raise ValueError(f"reader {name!r} has no suffix")
    if reader.name in _READERS:
        raise ValueError(f"a reader named {reader.name!r} is already registered")
    for s in reader.suffixes:
        if s in _BY_SUFFIX:
            raise ValueError(f"files {s} are already read by {_BY_SUFFIX[s]!r}")
    _READERS[reader.name] = reader
    for s in reader.suffixes:
        _BY_SUFFIX[s] = reader.name
    return reader


def unregister_reader(name: str) -> None:
    """Remove the reader ``name`` (KeyError if there is none)."""
    reader = _READERS.pop(name)
    for s in reader.suffixes:
        _BY_SUFFIX.pop(s, None)


def readers(*, project: bool | None = None) -> list[Reader]:
    """The registered readers in registration order; ``project`` True/False keeps
    only the readers of projects / of surfaces."""
    return [r for r in _READERS.values() if project is None or r.project == project]


def reader_for(path) -> Reader | None:
    """The reader of ``path``'s suffix (case-insensitive), or None."""
    name = _BY_SUFFIX.get(Path(path).suffix.lower())
    return None if name is None else _READERS[name]


def suffixes(*, project: bool | None = None) -> list[str]:
    """Every suffix with a reader, e.g. ``['.flatweave', '.json']`` (see :func:`readers`)."""
    return [s for r in readers(project=project) for s in r.suffixes]


def dialog_filter(*, project: bool | None = None) -> str:
    """A Qt file-dialog filter of the readers, "all supported" first, e.g.
    ``"All supported (*.flatweave *.json);;flatweave project (*.flatweave);;..."``."""
    chosen = readers(project=project)
    patterns = " ".join(f"*{s}" for r in chosen for s in r.suffixes)
    parts = [f"All supported ({patterns})"] + [
        f"{r.description} ({' '.join('*' + s for s in r.suffixes)})" for r in chosen]
    return ";;".join(parts)


def _example(name: str) -> tuple[Path, dict] | None:
    """(file, index entry) of the bundled example ``name``, or None."""

    if name not in example_names():
        return None
    return example_path(name), example_info(name)


def _example_at(path: Path) -> dict | None:
    """The index entry of the bundled example stored at ``path``, or None."""

    try:
        target = path.resolve()
        for entry in list_examples():
            if Path(example_path(entry["name"])).resolve() == target:
                return entry
    except (OSError, ValueError):
        pass
    return None


def open_path(path: str | os.PathLike, *, surface_only: bool = False) -> Opened:
    """Read a project or surface file, or a bundled example given by its name.

    ``path`` is a file whose suffix has a reader (:func:`suffixes`), or, when no
    such file exists and the name has no suffix, the name of a bundled example.
    A bundled example (by name or by its file) comes with its recommended
    spacing and units. With ``surface_only`` a project file is refused before
    it is read. Every problem is a one-line FlatweaveError.
    """
    p = Path(path)
    example = None
    if not exists(p) and not p.suffix:
        found = _example(str(path))
        if found is None:

            raise SettingsError(f"{str(path)!r} is neither a file nor a bundled example "
                                f"({', '.join(example_names())})")
        p, example = found
    reader = reader_for(p)
    if reader is None:
        allowed = suffixes(project=False if surface_only else None)
        raise SettingsError(f"cannot open {p}: unknown file type {p.suffix.lower() or '(no suffix)'!r}; "
                            f"use one of {', '.join(allowed)} or a bundled example name")
    if surface_only and reader.project:
        raise SettingsError(f"{p} is a {reader.description}, not a surface; give a surface file "
                            f"({', '.join(suffixes(project=False))}) or a bundled example name")
    got = reader.load(p)
    if isinstance(got, NurbsSurface):
        got = Opened(surface=got)
    elif not isinstance(got, Opened):
        raise TypeError(f"reader {reader.name!r} returned {type(got).__name__}, not a NurbsSurface or Opened")
    if got.project is not None and got.surface is None:
        got = dataclasses.replace(got, surface=got.project.surface)
    if example is None and got.project is None:
        example = _example_at(p)
    extras = {}
    if example is not None:
        extras = {"example": example["name"], "spacing": example.get("recommended_spacing"),
                  "units": example.get("units")}
        extras = {k: v for k, v in extras.items() if getattr(got, k) is None}
    return dataclasses.replace(got, path=got.path or p, source=got.source or str(p),
                               reader=got.reader or reader.name, **extras)


# ---------------------------------------------------------------------- today's readers
def _load_project(path: Path) -> Opened:
    project = load_project(path)
    return Opened(project=project, surface=project.surface)


def _load_geomdl_json(path: Path):
    surface, region = load_trimmed_surface(path)
    return surface if region is None else Opened(surface=surface, region=region)


# ".flatweave" is flatweave.document.project.PROJECT_SUFFIX, written out so that importing the
# registry does not import the project module (a test checks they agree).
def _load_job(path: Path) -> Opened:
    project = load_job(path, open_path)
    return Opened(project=project, surface=project.surface)


register_reader("flatweave-project", (".flatweave",), _load_project, "flatweave project", project=True)
register_reader("flatweave-job", (".toml",), _load_job, "flatweave job: a laminate's plies in TOML", project=True)
register_reader("geomdl-json", (".json",), _load_geomdl_json, "geomdl JSON surface")


def _load_cad(path: Path) -> Opened:
    """A STEP or IGES file (:func:`flatweave.reading.cad.read_cad_faces`): its faces, the
    file's units, and, when it has one face, that face chosen."""

    cad = read_cad_faces(path)
    opened = Opened(cad=cad, units=cad.units)
    return opened.with_face(0) if len(cad.faces) == 1 else opened


register_reader("step", (".step", ".stp"), _load_cad, "STEP faces")
register_reader("iges", (".iges", ".igs"), _load_cad, "IGES faces")


def _load_mesh(path: Path) -> Opened:
    """A triangle mesh (:func:`flatweave.geometry.meshfit.open_mesh`): repaired, mapped to
    the plane and fitted with a bicubic surface; its boundary is the region."""

    return open_mesh(path)


for _mesh_suffix, _description in MESH_SUFFIXES.items():
    register_reader(_mesh_suffix.lstrip("."), (_mesh_suffix,), _load_mesh, _description)
