"""What a file opened as: :class:`Opened`, the one answer of every reader."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from flatweave.errors import SettingsError
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.document.project import Project
from flatweave.geometry.region import region_from_cad_face
from flatweave.document.project import UNITS, new_project


@dataclass(frozen=True)
class Opened:
    """What :func:`open_path` read.

    path : the file read (for a bundled example, its file)
    source : ``str(path)``, as recorded in results and projects
    surface : the surface (a project's surface for a project file)
    project : the project for a project file, else None
    spacing : recommended mesh spacing in model units (bundled examples), else None
    units : model units when the file says (bundled examples: their units), else None
    units_guess : for a file that carries no units (a mesh), the unit its size suggests
        (:func:`flatweave.reading.meshes.guess_units`), which a new project takes
    example : the bundled example's name, else None
    reader : name of the reader that parsed the file
    region : the piece's region of the surface's domain (a trimmed CAD
        face, :class:`flatweave.geometry.region.Region`), or None for the whole domain
    cad : a STEP or IGES file's faces (:class:`flatweave.reading.cad.CadFile`), else None
    face : which of them ``surface`` and ``region`` are (None while a file
        with several faces has none chosen: :meth:`with_face`)
    mesh : a mesh file of several parts (:class:`flatweave.geometry.meshfit.MeshFile`);
        ``--face N`` / :meth:`with_face` chooses part N (0 = the largest)
    notes : one-line warnings about the input itself (a mesh far from
        developable flattened whole), which a result made from it keeps
    """

    path: Path | None = None
    source: str = ""
    surface: NurbsSurface | None = None
    project: Project | None = None
    spacing: float | None = None
    units: str | None = None
    example: str | None = None
    reader: str = ""
    region: Any = None
    cad: Any = None
    face: int | None = None
    mesh: Any = None  # a mesh file of several parts (flatweave.geometry.meshfit.MeshFile), until one is chosen
    units_guess: str | None = None
    notes: tuple[str, ...] = ()

    def refitted(self, tolerance: float) -> "Opened":
        """The mesh part chosen (``face``, 0 when None) fitted to ``tolerance`` in model
        units (:meth:`flatweave.reading.meshes.MeshFile.piece`); a one-line error when not met."""
        piece = self.mesh.piece(self.face or 0, tolerance)
        return dataclasses.replace(self, surface=piece.surface, region=piece.region)

    def with_face(self, index) -> "Opened":
        """The CAD file's face ``index`` (its surface, region and units); a
        one-line SettingsError when there is no such face."""
        if self.cad is None and self.mesh is not None:
            piece = self.mesh.piece(index)
            return dataclasses.replace(self, surface=piece.surface, region=piece.region, face=int(index))
        if self.cad is None:
            raise SettingsError(f"{self.source or self.path}: --face is for STEP and IGES files and meshes of "
                                f"several parts")
        face = self.cad.face(index)
        return dataclasses.replace(self, surface=face.surface, region=region_from_cad_face(face), face=face.index)

    def choose_face(self, index=None) -> "Opened":
        """A CAD file's face ``index``, or its only face when ``index`` is None;
        a one-line SettingsError saying how to choose when there are several."""
        if self.cad is None and self.mesh is not None:
            if self.surface is not None:
                return self
            if self.mesh.needs_region:
                raise SettingsError(self.mesh.needs_region)
            if index is not None:
                return self.with_face(index)
            n, name = self.mesh.n_parts, self.mesh.path.name
            raise SettingsError(f"{name} has {n} separate parts: choose one with --face N (0 = the largest, "
                                f"to {n - 1})")
        if self.cad is None:
            if index is not None:
                raise SettingsError(f"{self.source or self.path}: --face is for STEP and IGES files and "
                                    f"meshes of several parts")
            return self
        if index is None:
            if self.face is not None:
                return self
            n = len(self.cad.faces)
            name = Path(self.cad.path).name
            raise SettingsError(f"{name} has {n} faces: choose one with --face N (0 to {n - 1}; "
                                f"'python -m flatweave info {name}' lists them)")
        return self.with_face(index)

    @property
    def name(self) -> str:
        """A short name: the example's, the project's, or the file's stem."""
        if self.example:
            return self.example
        if self.project is not None:
            return self.project.name
        return self.path.stem if self.path is not None else "untitled"

    def as_project(self) -> Project:
        """The project: the file's own, or a new one for the surface with the
        recommended spacing (default: about sqrt(area)/25) and units (the file's, else the
        guess from a mesh's size, else m)."""

        if self.project is not None:
            return self.project
        units = self.units if self.units in UNITS else self.units_guess if self.units_guess in UNITS else "m"
        if self.surface is None:
            self.choose_face()  # raises: a CAD file with several faces and none chosen
        return new_project(self.surface, self.name if self.path is None else self.path.stem, self.source,
                           self.spacing, units, region=self.region)
