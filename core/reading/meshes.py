"""Mesh files (STL, OBJ, PLY, OFF): checked, read, and made into pieces.

:func:`check_mesh_file` compares what a file's header claims with its size
(a truncated binary STL or a header claiming gigabytes is refused at once,
before anything is allocated); :func:`read_mesh` parses it with trimesh;
:func:`open_mesh` makes it a surface and region by the steps of
:mod:`flatweave.geometry.meshfit` (clean, map, fit), or, for a file of several
parts, a :class:`MeshFile` to choose one from. :func:`fit_mesh` reads a fitted
surface's mesh back for the deviation view.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flatweave.errors import SettingsError
from flatweave.errors import SurfaceError
from flatweave.files import check_input
from flatweave.geometry.meshfit import FitMesh
from flatweave.geometry.meshfit import FittedSurface
from flatweave.geometry.meshfit import MAP_DISTORTION_LIMIT
from flatweave.geometry.meshfit import MAX_TRIANGLES
from flatweave.geometry.meshfit import MeshPiece
from flatweave.geometry.meshfit import NeedsRegion
from flatweave.geometry.meshfit import TooDetailed
from flatweave.geometry.meshfit import NonManifold
from flatweave.geometry.meshfit import SeveralParts
from flatweave.geometry.meshcut import closest_on_mesh
from flatweave.geometry.meshcut import cut_mesh
from flatweave.geometry.meshcut import cut_seam, drawn_loop_on_mesh
from flatweave.geometry.meshfit import check_coordinates
from flatweave.geometry.meshfit import clean_mesh
from flatweave.geometry.meshfit import mesh_surface
from flatweave.geometry.meshfit import open_ends
from flatweave.geometry.meshfit import used_vertices
from flatweave.document.project import UNITS
from flatweave.geometry.region import RegionDrawing
from flatweave.reading.opened import Opened


MESH_SUFFIXES = (".stl", ".obj", ".ply", ".off")


# --------------------------------------------------------------------------- reading
_PLY_SIZES = {"char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2, "int16": 2, "uint16": 2,
              "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4, "float32": 4, "double": 8, "float64": 8}


def _claim(name: str, n_tri: int, n_bytes: int, size: int) -> None:
    """Refuse a header whose counts the file cannot hold, before any allocation."""
    if n_tri > MAX_TRIANGLES:
        raise SurfaceError(f"{name}: the header claims {n_tri:,} triangles ({n_bytes / 2**30:.3g} GB); "
                           f"at most {MAX_TRIANGLES:,} are read")
    if n_bytes > size:
        raise SurfaceError(f"{name} is truncated: its header claims {n_tri:,} triangles ({n_bytes:,} bytes) "
                           f"but the file has {size:,} bytes")


def check_mesh_file(path) -> str:
    """Check what a mesh file's header claims against its size; returns the
    trimesh file type. One-line SurfaceError on a file that cannot be right."""
    p = Path(path)
    name = p.name
    check_input(p, "mesh", SurfaceError)
    try:
        size = p.stat().st_size
        with open(p, "rb") as fh:
            head = fh.read(65536)
    except OSError as exc:
        raise SurfaceError(f"cannot read {p}: {exc.strerror or exc}") from None
    if size == 0:
        raise SurfaceError(f"{name} is empty")
    suffix = p.suffix.lower()
    if suffix == ".stl":
        if size >= 84:
            n = int(np.frombuffer(head[80:84], "<u4")[0])
            if size == 84 + 50 * n:
                if n == 0:
                    raise SurfaceError(f"{name} has no triangles")
                _claim(name, n, 84 + 50 * n, size)
                return "stl"
        text = head.lstrip().lower()
        if text.startswith(b"solid") and (b"facet" in text or size < 1024 or b"endsolid" in text):
            # ASCII: a facet takes at least ~100 bytes; no header to check beyond that
            if size / 100 > MAX_TRIANGLES * 3:
                raise SurfaceError(f"{name} is too large ({size:,} bytes) to be a mesh of at most "
                                   f"{MAX_TRIANGLES:,} triangles")
            return "stl"
        if size < 84:
            raise SurfaceError(f"{name} is truncated: {size} bytes, less than a binary STL header (84)")
        n = int(np.frombuffer(head[80:84], "<u4")[0])
        _claim(name, n, 84 + 50 * n, size)
        raise SurfaceError(f"{name} is not a binary STL: its header claims {n:,} triangles "
                           f"({84 + 50 * n:,} bytes) but the file has {size:,} bytes")
    if suffix == ".ply":
        end = head.find(b"end_header")
        if not head.startswith(b"ply") or end < 0:
            raise SurfaceError(f"{name} is not a PLY file (no 'ply ... end_header' header)")
        lines = head[:end].decode("ascii", "replace").splitlines()
        fmt = next((ln.split()[1] for ln in lines if ln.startswith("format ") and len(ln.split()) > 1), "ascii")
        counts, record, current = {}, {}, None
        for ln in lines:
            w = ln.split()
            if len(w) >= 3 and w[0] == "element":
                current = w[1]
                try:
                    counts[current] = int(w[2])
                except ValueError:
                    raise SurfaceError(f"{name}: bad PLY element line {ln!r}") from None
                record[current] = 0
            elif len(w) >= 3 and w[0] == "property" and current is not None:
                if w[1] == "list" and len(w) >= 5:  # at least the count and three indices
                    record[current] += _PLY_SIZES.get(w[2], 1) + 3 * _PLY_SIZES.get(w[3], 1)
                else:
                    record[current] += _PLY_SIZES.get(w[1], 1)
        nv, nf = counts.get("vertex", 0), counts.get("face", 0)
        if nf == 0:
            raise SurfaceError(f"{name} has no triangles (no faces in its header)")
        body = size - end - len(b"end_header")
        if fmt == "ascii":  # "x y z\n" and "3 a b c\n" take at least 6 and 8 bytes
            need = 6 * nv + 8 * nf
        else:
            need = sum(counts[k] * record[k] for k in counts)
        _claim(name, nf, need, body)
        return "ply"
    if suffix == ".off":
        words = re.sub(rb"#[^\n]*", b"", head).split()
        if not words or not words[0].upper().endswith(b"OFF"):
            raise SurfaceError(f"{name} is not an OFF file (it does not start with 'OFF')")
        try:
            nv, nf = int(words[1]), int(words[2])
        except (IndexError, ValueError):
            raise SurfaceError(f"{name}: the OFF header has no vertex and face counts") from None
        if nf == 0:
            raise SurfaceError(f"{name} has no triangles")
        _claim(name, nf, 6 * nv + 8 * nf, size)
        return "off"
    if suffix == ".obj":
        if size / 8 > MAX_TRIANGLES * 3:  # "f 1 2 3\n" is 8 bytes
            raise SurfaceError(f"{name} is too large ({size:,} bytes) for at most {MAX_TRIANGLES:,} triangles")
        return "obj"
    raise SurfaceError(f"{name}: not a mesh file ({', '.join(MESH_SUFFIXES)})")


def read_mesh(path) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (n, 3) float, triangles (m, 3) int) of a mesh file, as
    written (polygons split into triangles by trimesh); nothing repaired."""
    file_type = check_mesh_file(path)
    name = Path(path).name
    try:
        import trimesh
    except ImportError:
        raise SurfaceError(f"{name}: reading meshes needs trimesh (pip install 'flatweave[mesh]')") from None
    import logging
    logging.getLogger("trimesh").setLevel(logging.ERROR)  # it logs what it skips; we say what matters
    try:
        with open(path, "rb") as fh:
            loaded = trimesh.load(fh, file_type=file_type, process=False, force="mesh")
    except Exception as exc:  # the parser's own complaint, in one line
        text = " ".join(str(exc).split())[:200] or type(exc).__name__
        raise SurfaceError(f"{name} cannot be read as {file_type.upper()}: {text}") from None
    V = np.asarray(getattr(loaded, "vertices", np.zeros((0, 3))), dtype=float).reshape(-1, 3)
    F = np.asarray(getattr(loaded, "faces", np.zeros((0, 3))), dtype=np.int64).reshape(-1, 3)
    if len(F) == 0:
        raise SurfaceError(f"{name} has no triangles")
    if F.min() < 0 or F.max() >= len(V):
        raise SurfaceError(f"{name}: a triangle refers to a vertex that is not in the file")
    return V, F


def load_mesh_piece(path, component: int | None = None) -> MeshPiece:
    """Read, repair and fit the mesh file ``path`` (``component``: which part
    of a mesh of several, 0 = the largest)."""
    p = Path(path)
    V, F = read_mesh(p)
    V, F, repairs = clean_mesh(V, F, p.name, component)
    return mesh_surface(V, F, source=os.fspath(p), name=p.name, repairs=repairs)


@dataclass(frozen=True, eq=False)
class MeshFile:
    """A mesh file as read: its parts, and the pieces cut from it.

    needs_region : why the mesh cannot be covered whole (closed, handles); "" when it can
    advice : why one piece would cover it badly (its conformal map's area
        distortion above MAP_DISTORTION_LIMIT) so a panel should be drawn; "" when not
    """

    path: Path
    vertices: np.ndarray
    triangles: np.ndarray
    n_parts: int  # 0: not counted (read only to cut a drawn piece from, mesh_to_cut)
    needs_region: str = ""
    advice: str = ""
    n_ends: int = 0  # open ends (2 or more: a seam can open it, meshfit.open_ends); 0: not counted
    cleaned: tuple | None = None  # (V, F, repairs) of clean_mesh when the open made them (info need not again)

    def piece(self, component: int, tolerance: float | None = None) -> MeshPiece:
        """Part ``component`` (0 = the largest) whole, fitted to ``tolerance``
        (model units; None: the default, :func:`flatweave.geometry.meshfit.mesh_surface`)."""
        if self.needs_region:
            raise SettingsError(self.needs_region)
        V, F, repairs = clean_mesh(self.vertices, self.triangles, self.path.name, component)
        return mesh_surface(V, F, source=os.fspath(self.path), name=self.path.name, repairs=repairs,
                            tolerance=tolerance)

    def cut_spec(self, spec, component: int | None = None, tolerance: float | None = None) -> MeshPiece:
        """The piece a ``--region`` spec draws on the mesh: ``{"loop3d": [[x, y, z],
        ...], "holes3d": [loop, ...]}`` (points on it), or ``{"points": [[x, y, z],
        ...], "view_direction": [dx, dy, dz], "holes": [points, ...]}`` (drawn
        points seen along the view, as on a surface: each side projected onto
        the mesh, :func:`flatweave.geometry.meshcut.drawn_loop_on_mesh`)."""
        name = self.path.name
        if isinstance(spec, dict) and "loop3d" in spec and "points" not in spec:
            holes = spec.get("holes3d", [])
            if not isinstance(holes, list):
                raise SettingsError('a mesh region\'s "holes3d" must be a list of loops of [x, y, z] points')
            return self.cut(spec["loop3d"], component, holes, tolerance)
        if isinstance(spec, dict) and "points" in spec and "loop3d" not in spec:
            drawing = RegionDrawing.from_dict(spec)  # validated as a drawn region on a surface is
            V, F = self.vertices, self.triangles
            check_coordinates(V[used_vertices(F)], name)  # before any arithmetic on them
            view = drawing.view_direction
            loop = drawn_loop_on_mesh(V, F, drawing.outer, view, name)
            holes3d = [drawn_loop_on_mesh(V, F, h, view, name, f"hole {k + 1} of the region")
                       for k, h in enumerate(drawing.holes)]
            return self.cut(loop, component, holes3d, tolerance)
        raise SettingsError(f"a region on {name} (a mesh) is {{\"loop3d\": [[x, y, z], ...]}} (a closed loop on it, "
                            f"\"holes3d\" inside it if any) or {{\"points\": [[x, y, z], ...], \"view_direction\": "
                            f"[dx, dy, dz]}} (drawn as seen along the view)")

    def seam_spec(self, spec, component: int | None = None, tolerance: float | None = None) -> MeshPiece:
        """The mesh opened along the seam a ``--seam`` spec draws on it:
        ``{"seam3d": [[x, y, z], ...]}`` (points on it, in order, from one open
        end to another), or ``{"points": [[x, y, z], ...], "view_direction":
        [dx, dy, dz]}`` (drawn points seen along the view, each side projected
        onto the mesh); see :func:`flatweave.geometry.meshcut.cut_seam`."""
        name = self.path.name
        if isinstance(spec, dict) and "seam3d" in spec and "points" not in spec:
            return self.cut_along(spec["seam3d"], component, tolerance)
        if isinstance(spec, dict) and "points" in spec and "seam3d" not in spec:
            view = np.asarray(spec.get("view_direction", np.nan), dtype=float) \
                if isinstance(spec.get("view_direction"), list) else None
            if view is None or view.shape != (3,) or not np.isfinite(view).all() or not np.linalg.norm(view) > 0:
                raise SettingsError('a drawn seam\'s "view_direction" must be a nonzero [dx, dy, dz]')
            V, F = self.vertices, self.triangles
            check_coordinates(V[used_vertices(F)], name)  # before any arithmetic on them
            seam = drawn_loop_on_mesh(V, F, spec["points"], view, name, "the seam", closed=False)
            return self.cut_along(seam, component, tolerance)
        raise SettingsError(f"a seam on {name} (a mesh) is {{\"seam3d\": [[x, y, z], ...]}} (points on it from one "
                            f"open end to another) or {{\"points\": [[x, y, z], ...], \"view_direction\": "
                            f"[dx, dy, dz]}} (drawn as seen along the view)")

    def cut_along(self, seam3d, component: int | None = None, tolerance: float | None = None) -> MeshPiece:
        """The mesh opened along a seam of 3D points drawn on it from one open
        end to another (:func:`flatweave.geometry.meshcut.cut_seam`), on part
        ``component`` (default: the part the seam is drawn on), fitted to
        ``tolerance`` (as :meth:`piece`)."""
        if component is None:
            component = _first_point(seam3d)
        V, F, repairs = clean_mesh(self.vertices, self.triangles, self.path.name, component)
        V, F = cut_seam(V, F, seam3d, self.path.name)
        return mesh_surface(V, F, source=os.fspath(self.path), name=self.path.name,
                            repairs=repairs + ("cut along a drawn seam",), tolerance=tolerance)

    def cut(self, loop3d, component: int | None = None, holes3d=(), tolerance: float | None = None) -> MeshPiece:
        """The piece inside a closed loop of 3D points drawn on the mesh, less the
        loops ``holes3d`` drawn inside it (:func:`flatweave.geometry.meshcut.cut_mesh`),
        on part ``component`` (default: the part the loop is drawn on), fitted
        to ``tolerance`` (as :meth:`piece`)."""
        if component is None:  # the part the loop is drawn on
            component = _first_point(loop3d)
        aside = []  # non-manifold edges: the piece must not reach them
        V, F, repairs = clean_mesh(self.vertices, self.triangles, self.path.name, component, aside=aside)
        V, F = cut_mesh(V, F, loop3d, self.path.name, holes3d)
        if aside:
            _, _, _, dist = closest_on_mesh(V, F, np.asarray(aside))
            touched = np.flatnonzero(dist <= 1e-6 * float(np.linalg.norm(np.ptp(V, axis=0))))
            if len(touched):
                x, y, z = aside[touched[0]]
                raise SettingsError(f"the loop drawn on {self.path.name} encloses or touches a non-manifold part "
                                    f"of it (edges of more than two triangles, one near "
                                    f"({x:.4g}, {y:.4g}, {z:.4g})); draw the loop clear of it or repair the mesh")
        return mesh_surface(V, F, source=os.fspath(self.path), name=self.path.name,
                            repairs=repairs + ("cut along a drawn loop",), tolerance=tolerance)


def _first_point(points):
    """The first of drawn ``points`` (the part of the mesh they are drawn on), or None when they
    are not points (the cut says what is wrong with them)."""
    try:
        return np.asarray(points, dtype=float).reshape(-1, 3)[0]
    except (TypeError, ValueError, IndexError):
        return None


MESH_SUFFIXES = {".stl": "STL mesh", ".obj": "OBJ mesh", ".ply": "PLY mesh", ".off": "OFF mesh"}
"""The mesh formats (trimesh reads them), each a reader of :mod:`flatweave.reading.registry`."""


def is_mesh_path(path) -> bool:
    """Whether ``path`` is a mesh file by its suffix."""
    return Path(path).suffix.lower() in MESH_SUFFIXES


def mesh_to_cut(path) -> Opened:
    """A mesh file read to cut a drawn piece from (``--region`` on a mesh): its
    :class:`MeshFile` (``n_parts`` not counted: the cut takes the part under
    the loop) and units guess, without the whole mesh's map and fit, which
    :func:`open_mesh` makes and a drawn piece does not need."""
    p = Path(path)
    V, F = read_mesh(p)
    return Opened(mesh=MeshFile(p, V, F, 0), units_guess=_units_guess(V, F), path=p, source=str(p),
                  reader=p.suffix.lower().lstrip("."))


def _units_guess(V, F) -> str | None:
    used = V[used_vertices(F)]
    try:
        check_coordinates(used)
    except SurfaceError:  # no guess: clean_mesh refuses the file in one line
        return None
    return guess_units(float(np.linalg.norm(np.ptp(used, axis=0))))


def open_mesh(path):
    """The reader of :mod:`flatweave.reading.registry`: an ``Opened`` with the surface and
    region of a one-part mesh (and its :class:`MeshFile`, ``Opened.mesh``, to cut a
    panel from), or, for several parts or a mesh that needs a region, the
    :class:`MeshFile` alone, to choose a part from (``Opened.choose_face``) or
    draw the piece on."""

    p = Path(path)
    V, F = read_mesh(p)
    guess = _units_guess(V, F)
    try:
        V2, F2, repairs = clean_mesh(V, F, p.name)
    except SeveralParts as exc:
        return Opened(mesh=MeshFile(p, V, F, exc.n_parts), units_guess=guess)
    except NonManifold as exc:  # a panel drawn clear of those edges can still be cut
        n = str(exc).split(";")[0]  # "NAME has N non-manifold edges (shared by more than two triangles)"
        return Opened(mesh=MeshFile(p, V, F, 1, f"{n}: it cannot be covered whole, but a panel drawn clear of them "
                                                f"can be cut (--region); or repair the mesh"), units_guess=guess)
    try:
        piece = mesh_surface(V2, F2, source=os.fspath(p), name=p.name, repairs=repairs)
    except (NeedsRegion, TooDetailed) as exc:  # closed, handles, too detailed: a panel drawn on it says which piece
        return Opened(mesh=MeshFile(p, V, F, 1, str(exc), cleaned=(V2, F2, repairs)), units_guess=guess)
    ends = open_ends(V2, F2)
    advice = panel_advice(p.name, piece.fit, ends)
    return Opened(surface=piece.surface, region=piece.region, mesh=MeshFile(p, V, F, 1, advice=advice, n_ends=ends),
                  units_guess=guess)


UNIT_GUESS_ORDER = ("mm", "cm", "m")  # tried in this order (mm is the usual case); inches are chosen, not guessed
PLAUSIBLE_SIZE_M = (0.1, 3.0)  # a piece's bounding-box diagonal in metres, from a shoe upper to a car seat


def guess_units(size: float) -> str:
    """The model unit a mesh ``size`` units across (its bounding-box diagonal)
    is most likely in: the first of mm, cm, m that makes it 0.1 to 3 m
    across (a 300-unit head is millimetres, a 30-unit one centimetres); when
    none does, the one that brings it nearest 0.5 m."""
    for unit in UNIT_GUESS_ORDER:
        if PLAUSIBLE_SIZE_M[0] <= size * UNITS[unit] <= PLAUSIBLE_SIZE_M[1]:
            return unit
    return min(UNIT_GUESS_ORDER, key=lambda u: abs(np.log(max(size * UNITS[u], 1e-300) / 0.5)))


def units_note(name: str, size: float, units: str) -> str:
    """One line: the mesh carries no units, its size, and the unit taken for it."""
    return (f"{name} carries no units: it is {size:.4g} units across, taken as {units} "
            f"(a {size * UNITS[units]:.3g} m piece)")


def panel_advice(name: str, fit, n_ends: int = 1) -> str:
    """Why a panel (or, with ``n_ends`` open ends, 2 or more, a seam) should
    be drawn on the mesh ``fit`` (a MeshFit) records, or "" (see
    MAP_DISTORTION_LIMIT)."""
    if fit is None or fit.map_distortion <= MAP_DISTORTION_LIMIT:
        return ""
    if n_ends >= 2:  # a tube: whole, its map is a ring, squeezed towards one end; cut open, it may lie flat
        return (f"{name} is open at {n_ends} ends, like a tube (its flat map changes areas by "
                f"{100 * fit.map_distortion:.0f} %): one piece covers it only cut open; draw a seam on it from "
                f"one end to another, or a panel")
    return (f"{name} is far from developable (its flat map changes areas by {100 * fit.map_distortion:.0f} %): "
            f"one piece covers it badly; draw a panel on it")


def fit_mesh(surface: FittedSurface) -> FitMesh:
    """The mesh ``surface`` was fitted to: the one it was made from, or, for a
    reopened project (which keeps the surface, not the mesh), its source file
    read and mapped again (the same steps give the same map). A one-line
    SurfaceError when that file is gone, changed, or was cut along a loop."""
    mesh = getattr(surface, "mesh", None)
    if mesh is not None:
        return mesh
    fit = getattr(surface, "fit", None)
    if fit is None:
        raise SurfaceError("the surface was not fitted to a mesh")
    path = Path(fit.source)
    if any(r.startswith("cut along") for r in fit.repairs):
        raise SurfaceError(f"{path.name} was cut along a drawn loop: open the mesh again to see it")
    if not path.is_file():
        raise SurfaceError(f"the mesh {fit.source} the surface was fitted to is not there any more")
    piece = load_mesh_piece(path)
    if (piece.fit.vertices, piece.fit.triangles) != (fit.vertices, fit.triangles):
        raise SurfaceError(f"{path.name} has changed since the surface was fitted to it "
                           f"({piece.fit.vertices} vertices, was {fit.vertices})")
    surface.mesh = piece.surface.mesh
    return surface.mesh
