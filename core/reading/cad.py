"""Reading the faces of STEP and IGES files with Open CASCADE.

:func:`read_cad_faces` reads a ``.step``/``.stp`` (AP203, AP214, AP242) or
``.iges``/``.igs`` file and returns a :class:`CadFile`: the file's length
unit and every placed face as a :class:`CadFace`, a
:class:`~flatweave.geometry.nurbs.NurbsSurface` with its trim loops in (u, v).

How a file is read
------------------
Open CASCADE (the ``cadquery-ocp-novtk`` wheel, module ``OCP``) does the
reading, in a child process: OCCT can kill its process on some malformed
faces, so a crash or a hang of the child becomes a one-line
:class:`CadFileError` naming the file. The child sends back plain numbers
(numpy arrays, dicts), never OCCT objects. ``OCP`` is imported only there:
``import flatweave.reading.cad`` works without it, and reading a CAD file then raises
:class:`CadUnavailableError` saying how to install it.

In the child:

- STEP: ``STEPControl_Reader``; the file's length unit is the first of its
  representations' units (``FileUnits``) and the reader's system unit is set
  to it (``SetSystemLengthUnit``), so lengths come out in the file's units,
  not in OCCT's default millimetres. IGES: ``IGESControl_Reader``; the unit
  is the global section's unit flag and the cascade unit is set to it. A file
  whose unit OCCT names but this module does not know is read in millimetres
  and says so (``units == "mm"``).
- The whole shape is converted with ``BRepBuilderAPI_NurbsConvert`` before
  faces are taken apart (converting one surface at a time re-parametrises
  analytic surfaces, and the trims no longer fit). Faces are taken in
  ``TopExp_Explorer`` order: an assembly that places one face several times
  gives one :class:`CadFace` per placement, with the placement applied.
  When OCCT refuses the whole shape (it does for a periodic B-spline face
  that crosses the end of its knot range), faces are converted one by one,
  and a B-spline or Bezier face that still fails is used as it is.
- The original face's surface type is the face's :attr:`CadFace.kind`; its
  area is ``BRepGProp`` surface properties of the original face (adaptive, to
  1e-10 relative); its tolerance the largest of its edges' tolerances, and
  its trim deviation the largest distance measured between an edge's curve
  on the face and its 3D curve.
- A periodic B-spline is made non-periodic (``SetUNotPeriodic``) after its
  origin is moved, when needed, to where the face's loops begin, so that the
  loops lie in the domain.
- Loops: the outer wire (``BRepTools.OuterWire``) first, then the others;
  each wire's edges in order (``BRepTools_WireExplorer``), each edge's curve
  on the face over its range, walked backwards for a reversed edge, sampled
  adaptively until no chord is further than ``chord_tol`` times the face's
  (u, v) box diagonal from its curve. Edge ends (the corners) are samples.

Back in the caller, a reversed face (its normal is -Su x Sv) is flipped by
u -> a + b - u on the knots, the control rows, the weights and the loops,
so that Su x Sv is the face's normal; loops are clipped to the domain (they
may stick out by a fraction of a percent), the outer loop is made
counter-clockwise and the holes clockwise (it is already, after the flip;
a file that says otherwise is believed on the loops, not on their sense).
The box is :func:`flatweave.geometry.uvregion.region_bbox` of the loops' region.

Measured on the test files (tests/test_cad.py, OCP 8.0.1): the surfaces
agree with OCCT's evaluation to 6e-14, the loops lie on OCCT's 3D edges as
closely as the file's own pcurves do (within 0.94 of max(tolerance,
trim deviation)), the polygon regions' areas agree with ``BRepGProp`` to
2.4e-7 relative, and a small file takes about 1.6-2 s to read, most of it
the child's start and OCP's import.

Several faces joined
--------------------
:func:`join_faces` (``--faces 2,5,7``, the face picker's shift-click) makes
one surface of adjacent faces by the mesh route: a child tessellates them
(``BRepMesh_IncrementalMesh``) and sends each face's nodes, triangles,
normals and the node chains of its edges; the chains of shared edges are
welded (:func:`flatweave.geometry.meshfit.weld_parts`), long triangles filled
(:func:`flatweave.geometry.meshfit.densify`), and the mesh is repaired, mapped and fitted
as a mesh file is (:func:`flatweave.geometry.meshfit.mesh_surface`). Faces that share no
edge with the others, or that close up, are refused in one line.

Errors
------
Every problem is a one-line :class:`~flatweave.errors.FlatweaveError`:
:class:`CadFileError` (a :class:`~flatweave.errors.SurfaceError`) for a file that
cannot be read (missing, empty, truncated, not STEP/IGES, no faces, a face
that cannot be converted, a crash or timeout of the child),
:class:`CadUnavailableError` when Open CASCADE is not installed, and
:class:`~flatweave.errors.SettingsError` for a face index out of range
(:meth:`CadFile.face`).
"""

from __future__ import annotations

import os
import pickle
import signal
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flatweave.errors import SettingsError, SurfaceError
from flatweave.files import check_input
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.geometry.uvregion import region_bbox
from flatweave.geometry.numerics import polygon_area

__all__ = [
    "CadFace",
    "CadFile",
    "CadFileError",
    "CadUnavailableError",
    "read_cad_faces",
    "face_table",
    "cad_info",
    "is_cad_path",
    "CAD_SUFFIXES",
    "INSTALL_HINT",
    "DEFAULT_TIMEOUT",
    "DEFAULT_CHORD_TOL",
    "parse_face_list",
]

STEP_SUFFIXES = (".step", ".stp", ".p21")
IGES_SUFFIXES = (".iges", ".igs")
CAD_SUFFIXES = STEP_SUFFIXES + IGES_SUFFIXES

INSTALL_HINT = "pip install cadquery-ocp-novtk (or: pip install 'flatweave[cad]')"

DEFAULT_TIMEOUT = 120.0
"""Seconds a child may take to read a file before it is killed
(``FLATWEAVE_CAD_TIMEOUT`` overrides it)."""

DEFAULT_CHORD_TOL = 1e-7
"""Largest distance of a loop chord from its curve, relative to the diagonal
of the face's (u, v) box. The polygon is inscribed in curved trims, so its
region's area is off by about (2/3) chord_tol x perimeter / area (in (u, v));
measured on the test faces: at most 2.4e-7 relative (a free-curve outer
loop), 1.9e-7 for a disc. A circle across the face takes about 6,600 points,
one of a fifth of it 2,500-5,000."""

FAULT_ENV = "FLATWEAVE_CAD_FAULT"
"""Testing hook read by the child: ``abort`` (die by SIGABRT), ``hang``
(sleep forever), ``no-ocp`` (behave as if OCP were not installed)."""

_UNIT_NAMES = {  # STEP unit names (lower case) -> (our name, millimetres per unit)
    "millimetre": ("mm", 1.0), "millimeter": ("mm", 1.0),
    "centimetre": ("cm", 10.0), "centimeter": ("cm", 10.0),
    "decimetre": ("dm", 100.0), "decimeter": ("dm", 100.0),
    "metre": ("m", 1000.0), "meter": ("m", 1000.0),
    "kilometre": ("km", 1e6), "kilometer": ("km", 1e6),
    "micrometre": ("um", 1e-3), "micrometer": ("um", 1e-3), "micron": ("um", 1e-3),
    "nanometre": ("nm", 1e-6), "nanometer": ("nm", 1e-6),
    "inch": ("in", 25.4), "foot": ("ft", 304.8), "feet": ("ft", 304.8),
    "yard": ("yd", 914.4), "mile": ("mi", 1609344.0), "mil": ("mil", 0.0254),
    "microinch": ("uin", 2.54e-5),
}
_IGES_UNIT_FLAGS = {  # IGES global section unit flag -> (our name, millimetres per unit)
    1: ("in", 25.4), 2: ("mm", 1.0), 4: ("ft", 304.8), 5: ("mi", 1609344.0), 6: ("m", 1000.0),
    7: ("km", 1e6), 8: ("mil", 0.0254), 9: ("um", 1e-3), 10: ("cm", 10.0), 11: ("uin", 2.54e-5),
}
_IGES_UNIT_WORDS = {"IN": "inch", "INCH": "inch", "MM": "millimetre", "FT": "foot", "MI": "mile",
                    "M": "metre", "KM": "kilometre", "MIL": "mil", "UM": "micrometre",
                    "MICRON": "micrometre", "CM": "centimetre", "UIN": "microinch"}

_KINDS = {  # GeomAbs_SurfaceType names -> CadFace.kind
    "GeomAbs_Plane": "plane", "GeomAbs_Cylinder": "cylinder", "GeomAbs_Cone": "cone",
    "GeomAbs_Sphere": "sphere", "GeomAbs_Torus": "torus", "GeomAbs_BezierSurface": "bezier",
    "GeomAbs_BSplineSurface": "bspline", "GeomAbs_SurfaceOfRevolution": "revolution",
    "GeomAbs_SurfaceOfExtrusion": "extrusion", "GeomAbs_OffsetSurface": "offset",
    "GeomAbs_OtherSurface": "other",
}


class CadFileError(SurfaceError):
    """A CAD file cannot be read (one line naming the file and the problem)."""


class CadUnavailableError(CadFileError):
    """Open CASCADE (the ``OCP`` module) is not installed."""


# ====================================================================== results
@dataclass(frozen=True)
class CadFace:
    """One placed face of a CAD file.

    index : position in Open CASCADE's ``TopExp_Explorer`` order (every
        placement of a face shared by an assembly counts)
    kind : the file's surface type before the NURBS conversion: "plane",
        "cylinder", "cone", "sphere", "torus", "bspline", "bezier",
        "revolution", "extrusion", "offset" or "other"
    surface : the face's surface as a NurbsSurface (flipped in u when the face
        is reversed, so that Su x Sv is the face's normal), in the file's units
    loops_uv : (n_k, 2) float arrays in (u, v), outer loop first (counter-
        clockwise), then the holes (clockwise); each loop is closed
        implicitly (its last point joins its first; no point repeats)
    loop_breaks : (e_k,) int arrays, per loop the index of the point where
        each edge starts (0 first): the corners
    trimmed : False when the outer loop is the domain's rectangle (within the
        face's tolerance, at most 0.1 % of the domain) and there are no holes
    area : the face's area by Open CASCADE (``BRepGProp``), in units^2
    bbox : (xmin, ymin, zmin, xmax, ymax, zmax) of the face's region on the
        surface (:func:`flatweave.geometry.uvregion.region_bbox`)
    tolerance : the largest tolerance of the face's edges (and of the face),
        as the file (after Open CASCADE's conversion) states it
    trim_deviation : the largest distance measured between an edge's curve
        on the face and its 3D curve (at the loop's samples and at least 8
        points a knot span of the curve on the face); files can understate
        it: OCCT's own STEP and IGES writers gave 1e-5 on edges of tolerance
        1e-7. The loops are as accurate as max(tolerance, trim_deviation).
    reversed : whether the file's face is reversed relative to its surface
    """

    index: int
    kind: str
    surface: NurbsSurface
    loops_uv: tuple
    loop_breaks: tuple
    trimmed: bool
    area: float
    bbox: tuple
    tolerance: float
    trim_deviation: float
    reversed: bool


@dataclass(frozen=True)
class CadFile:
    """The faces of one CAD file.

    path : the file read
    format : "step" or "iges"
    units : the file's length unit ("mm", "cm", "m", "in", "ft", ...): every
        length (control points, bbox, tolerance) is in it, areas in its square
    mm_per_unit : millimetres per unit (1 for "mm", 25.4 for "in")
    faces : every placed face in TopExp_Explorer order
    """

    path: str
    format: str
    units: str
    mm_per_unit: float
    faces: tuple

    def face(self, index) -> CadFace:
        """Face ``index``; a one-line SettingsError when there is no such face."""
        n = len(self.faces)
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
            raise SettingsError(f"face index must be an integer, got {index!r}")
        if not 0 <= index < n:
            raise SettingsError(f"face index {index} is out of range: {Path(self.path).name} has {n} "
                                f"face{'s' if n != 1 else ''} (0 to {n - 1})")
        return self.faces[int(index)]


def face_table(cad_file: CadFile) -> list[dict]:
    """The ``info --json`` face entries: index, kind, area, trimmed, bbox."""
    return [{"index": f.index, "kind": f.kind, "area": float(f.area), "trimmed": bool(f.trimmed),
             "bbox": [float(x) for x in f.bbox]} for f in cad_file.faces]


def cad_info(cad_file: CadFile) -> dict:
    """What ``info PART.step --json`` prints: ``{"units": ..., "faces": face_table(...)}``."""
    return {"units": cad_file.units, "faces": face_table(cad_file)}


def is_cad_path(path) -> bool:
    """Whether path's suffix is a STEP or IGES one."""
    return Path(path).suffix.lower() in CAD_SUFFIXES


# ====================================================================== caller side
def _one_line(text, limit: int = 300) -> str:
    import re
    flat = re.sub(r"\s+", " ", str(text)).strip()
    return flat if len(flat) <= limit else flat[: limit - 3] + "..."


def _sniff(path: Path, fmt: str) -> None:
    """Cheap checks before a child is started: empty, binary, truncated, not STEP/IGES."""
    name = path.name
    size = check_input(path, "cad", CadFileError)  # missing, a folder, a pipe or a device: refused unopened
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
            fh.seek(max(0, size - 4096))
            tail = fh.read()
    except OSError as exc:
        raise CadFileError(f"{path}: cannot be read: {_one_line(exc.strerror or exc)}") from None
    if size == 0:
        raise CadFileError(f"{name}: the file is empty")
    if b"\x00" in head:
        raise CadFileError(f"{name}: not a {fmt.upper()} file (binary data)")
    head = head[3:] if head.startswith(b"\xef\xbb\xbf") else head
    if fmt == "step":
        if not head.lstrip().upper().startswith(b"ISO-10303-21"):
            raise CadFileError(f"{name}: not a STEP file (it does not begin with ISO-10303-21;)")
        if b"END-ISO-10303-21" not in tail.upper():
            raise CadFileError(f"{name}: the STEP file is truncated (no END-ISO-10303-21; at its end)")
    else:
        first = head.lstrip(b"\r\n").split(b"\n", 1)[0].rstrip(b"\r")
        if len(first) >= 73 and first[72:73] == b"B":
            raise CadFileError(f"{name}: binary IGES files cannot be read; save it as ASCII IGES")
        if len(first) < 73 or first[72:73] not in (b"S", b"G", b"C"):
            raise CadFileError(f"{name}: not an IGES file (its first line has no section letter in column 73)")


def read_timeout(timeout) -> float:
    if timeout is None:
        env = os.environ.get("FLATWEAVE_CAD_TIMEOUT", "")
        try:
            timeout = float(env) if env else DEFAULT_TIMEOUT
        except ValueError:
            raise SettingsError(f"FLATWEAVE_CAD_TIMEOUT must be a number of seconds, got {env!r}") from None
    if not timeout > 0:
        raise SettingsError(f"the CAD reading timeout must be positive, got {timeout!r}")
    return float(timeout)


def _signal_name(code: int) -> str:
    try:
        return signal.Signals(-code).name
    except ValueError:
        return f"signal {-code}"


def run_child(path: Path, fmt: str, chord_tol: float, timeout: float, task: tuple = ()) -> dict:
    """Read path in a child Python process; its result dict (or a one-line error).
    ``task``: extra words for the child (``("tessellate", "2,5,7", lin, ang)``
    tessellates those faces instead of reading them all)."""
    with tempfile.TemporaryDirectory(prefix="flatweave-cad-") as tmp:
        out = Path(tmp) / "result.pickle"
        cmd = [sys.executable, "-I", "-m", "flatweave.reading.cad", str(path), fmt, repr(float(chord_tol)), str(out),
               *map(str, task)]
        try:
            proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                    stderr=subprocess.PIPE, cwd=tmp)
        except OSError as exc:
            raise CadFileError(f"{path.name}: cannot start a process to read it: {_one_line(exc)}") from None
        try:
            _, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
            raise CadFileError(f"{path.name}: Open CASCADE took longer than {timeout:g} s to read the file; "
                               f"stopped (set FLATWEAVE_CAD_TIMEOUT for more)") from None
        except BaseException:  # interrupted (Ctrl-C, a GUI cancelling): no child left behind
            proc.kill()
            proc.communicate()
            raise
        if out.exists() and proc.returncode == 0:
            with open(out, "rb") as fh:
                result = pickle.load(fh)
        elif proc.returncode < 0:
            raise CadFileError(f"{path.name}: Open CASCADE crashed reading the file "
                               f"({_signal_name(proc.returncode)}); the file is probably malformed")
        else:
            lines = [ln for ln in err.decode("utf-8", "replace").splitlines() if ln.strip()]
            last = _one_line(lines[-1]) if lines else "no message"
            raise CadFileError(f"{path.name}: reading failed (exit status {proc.returncode}): {last}")
    if not result.get("ok"):
        cls = CadUnavailableError if result.get("missing") else CadFileError
        raise cls(result["error"])
    return result


def read_cad_faces(path, *, timeout: float | None = None, chord_tol: float = DEFAULT_CHORD_TOL) -> CadFile:
    """Read every face of a STEP or IGES file (in a child process).

    Parameters
    ----------
    path : a ``.step``/``.stp``/``.p21`` or ``.iges``/``.igs`` file
    timeout : seconds before a hanging child is killed (default
        ``FLATWEAVE_CAD_TIMEOUT`` or :data:`DEFAULT_TIMEOUT`)
    chord_tol : loop sampling accuracy, relative to each face's (u, v) box
        (see :data:`DEFAULT_CHORD_TOL`)

    Raises a one-line :class:`CadFileError` (or :class:`CadUnavailableError`)
    for any problem.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in STEP_SUFFIXES:
        fmt = "step"
    elif suffix in IGES_SUFFIXES:
        fmt = "iges"
    else:
        raise CadFileError(f"{path.name}: not a STEP (.step, .stp) or IGES (.iges, .igs) file name")
    if not (isinstance(chord_tol, (int, float)) and 0 < chord_tol < 0.1):
        raise SettingsError(f"chord_tol must be a number in (0, 0.1), got {chord_tol!r}")
    timeout = read_timeout(timeout)
    _sniff(path, fmt)
    result = run_child(path.resolve(), fmt, chord_tol, timeout)
    faces = tuple(_make_face(path.name, d) for d in result["faces"])
    return CadFile(path=str(path), format=fmt, units=result["units"], mm_per_unit=float(result["mm_per_unit"]),
                   faces=faces)


# ---------------------------------------------------------------------- several faces joined
def parse_face_list(text) -> tuple[int, ...]:
    """``"2,5,7"`` -> (2, 5, 7); a one-line SettingsError for anything else
    (not integers, a negative index, an index given twice)."""
    words = [w.strip() for w in str(text).split(",")]
    try:
        indices = tuple(int(w) for w in words)
    except ValueError:
        raise SettingsError(f"--faces takes face indices separated by commas, like 2,5,7; got {text!r}") from None
    for k, i in enumerate(indices):
        if i < 0:
            raise SettingsError(f"--faces: face index {i} is negative")
        if i in indices[:k]:
            raise SettingsError(f"--faces: face {i} is given twice in {text!r}")
    if not indices:
        raise SettingsError("--faces needs one face index or more")
    return indices


# ---------------------------------------------------------------------- faces from the child's data
def _reverse_loop(p: np.ndarray, breaks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The loop walked the other way, still starting at point 0 (a corner)."""
    n = len(p)
    return np.roll(p[::-1], 1, axis=0), np.unique((n - breaks) % n)


def _clean_loop(p: np.ndarray, breaks: np.ndarray, domain: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Clip to the domain and drop points equal to their predecessor (and a
    last point equal to the first)."""
    p = np.column_stack([np.clip(p[:, 0], domain[0, 0], domain[0, 1]),
                         np.clip(p[:, 1], domain[1, 0], domain[1, 1])])
    keep = np.ones(len(p), bool)
    keep[1:] = np.any(p[1:] != p[:-1], axis=1)
    if len(p) > 1 and np.all(p[-1] == p[0]):
        keep[-1] = False
    new_index = np.cumsum(keep) - 1
    return p[keep], np.unique(np.maximum(new_index[breaks], 0))


def _is_domain_rectangle(p: np.ndarray, domain: np.ndarray, eps: np.ndarray) -> bool:
    """Whether a loop runs along the domain's boundary all the way round,
    within eps = (eps_u, eps_v) in parameter units."""
    size = domain[:, 1] - domain[:, 0]
    on_edge = ((np.abs(p[:, 0] - domain[0, 0]) <= eps[0]) | (np.abs(p[:, 0] - domain[0, 1]) <= eps[0])
               | (np.abs(p[:, 1] - domain[1, 0]) <= eps[1]) | (np.abs(p[:, 1] - domain[1, 1]) <= eps[1]))
    slack = 2.0 * (eps[0] * size[1] + eps[1] * size[0])
    return bool(np.all(on_edge)) and abs(abs(polygon_area(p)) - size[0] * size[1]) <= slack


def _uv_tolerance(surface: NurbsSurface, loop: np.ndarray, tolerance: float) -> np.ndarray:
    """The face's 3D tolerance in parameter units along the loop (by the
    median speeds |S_u|, |S_v| there), at least 1e-9 and at most 1e-3 of the
    domain: a trim closer to the domain's edge than that trims nothing."""
    size = surface.domain[:, 1] - surface.domain[:, 0]
    _, su, sv = surface.derivatives(loop[:: max(1, len(loop) // 200)])
    speed = np.array([np.median(np.linalg.norm(su, axis=1)), np.median(np.linalg.norm(sv, axis=1))])
    with np.errstate(divide="ignore", invalid="ignore"):
        eps = np.where(speed > 0, tolerance / speed, np.inf)
    return np.clip(eps, 1e-9 * size, 1e-3 * size)


def flip_u(degree_u: int, knots_u: np.ndarray, ctrlpts: np.ndarray, weights: np.ndarray, loops):
    """u -> a + b - u on a surface's data and loops; [a, b] its u-domain."""
    n = ctrlpts.shape[0]
    a, b = knots_u[degree_u], knots_u[n]
    knots = (a + b) - knots_u[::-1]
    flipped = []
    for p in loops:
        q = p.copy()
        q[:, 0] = (a + b) - q[:, 0]
        flipped.append(q)
    return knots, ctrlpts[::-1].copy(), weights[::-1].copy(), flipped


def _make_face(name: str, d: dict) -> CadFace:
    index = d["index"]
    knots_u = np.asarray(d["knots_u"], float)
    ctrl, weights = np.asarray(d["ctrlpts"], float), np.asarray(d["weights"], float)
    loops = [np.asarray(p, float) for p in d["loops"]]
    breaks = [np.asarray(b, int) for b in d["breaks"]]
    if d["reversed"]:
        knots_u, ctrl, weights, loops = flip_u(d["degree_u"], knots_u, ctrl, weights, loops)
    try:
        surface = NurbsSurface(d["degree_u"], d["degree_v"], knots_u, d["knots_v"], ctrl, weights)
    except SurfaceError as exc:
        raise CadFileError(f"{name}: face {index} ({d['kind']}): {exc}") from None
    domain = surface.domain
    out_loops, out_breaks = [], []
    for k, (p, b) in enumerate(zip(loops, breaks)):
        p, b = _clean_loop(p, b, domain)
        if len(p) < 3 or abs(polygon_area(p)) <= 1e-14 * np.prod(domain[:, 1] - domain[:, 0]):
            if k == 0:
                raise CadFileError(f"{name}: face {index} ({d['kind']}) has an outer loop enclosing no area")
            continue  # a hole of no area (e.g. a slit) leaves the region as it is
        want_ccw = k == 0
        if (polygon_area(p) > 0) != want_ccw:
            p, b = _reverse_loop(p, b)
        for arr in (p, b):
            arr.setflags(write=False)
        out_loops.append(p)
        out_breaks.append(b)
    loops_t, breaks_t = tuple(out_loops), tuple(out_breaks)
    trimmed = len(loops_t) > 1 or not _is_domain_rectangle(
        loops_t[0], domain, _uv_tolerance(surface, loops_t[0], float(d["tolerance"])))
    return CadFace(index=index, kind=d["kind"], surface=surface, loops_uv=loops_t, loop_breaks=breaks_t,
                   trimmed=trimmed, area=float(d["area"]), bbox=region_bbox(surface, loops_t),
                   tolerance=float(d["tolerance"]), trim_deviation=float(d["trim_deviation"]),
                   reversed=bool(d["reversed"]))


# ====================================================================== child side
def _child_main(argv: list[str]) -> None:
    """Entry point of the child: read argv = [path, format, chord_tol, out] and
    pickle {"ok": True, ...} or {"ok": False, "error": one line} to out."""
    path, fmt, chord_tol, out = argv[0], argv[1], float(argv[2]), argv[3]
    task = argv[4:]
    fault = os.environ.get(FAULT_ENV, "")
    if fault == "abort":
        os.abort()
    if fault == "hang":
        import time
        while True:
            time.sleep(60)
    if fault == "no-ocp":
        sys.modules["OCP"] = None  # makes `import OCP` raise ImportError, as when it is not installed
    name = Path(path).name
    try:
        import OCP  # noqa: F401
    except ImportError:
        result = {"ok": False, "missing": True,
                  "error": f"{name}: reading {fmt.upper()} files needs Open CASCADE: {INSTALL_HINT}"}
    else:
        try:
            if task and task[0] == "tessellate":
                indices = [int(x) for x in task[1].split(",")]
                result = {"ok": True, **_occ_tessellate(path, fmt, indices, float(task[2]), float(task[3]))}
            else:
                result = {"ok": True, **_occ_read(path, fmt, chord_tol)}
        except CadFileError as exc:
            result = {"ok": False, "error": str(exc)}
        except Exception as exc:  # any OCCT failure is one line about the file
            result = {"ok": False, "error": f"{name}: Open CASCADE failed to read the file: "
                                            f"{type(exc).__name__}: {_one_line(exc)}"}
    tmp = out + ".part"
    with open(tmp, "wb") as fh:
        pickle.dump(result, fh, protocol=pickle.HIGHEST_PROTOCOL)
    os.replace(tmp, out)


class _Occ:
    """The OCP names the child uses, looked up once (7.x and 8.x differ:
    static methods with or without ``_s``, TopoDS casts, array classes)."""

    def __init__(self):
        import importlib

        def mod(name):
            return importlib.import_module("OCP." + name)

        self.mod = mod

    def static(self, module: str, cls: str, method: str):
        """A static method, ``Class.method_s`` (most of 7.x/8.x) or ``Class.method``."""
        c = getattr(self.mod(module), cls)
        f = getattr(c, method + "_s", None)
        return f if f is not None else getattr(c, method)

    def cls(self, *names: str):
        """The first of ``module.Class`` names that exists."""
        for name in names:
            module, _, attr = name.partition(".")
            try:
                return getattr(self.mod(module), attr)
            except (ImportError, AttributeError):
                continue
        raise ImportError(f"none of {names} in this OCP")


def _unit_from_step(occ: _Occ, reader) -> tuple[str, float]:
    Seq = occ.cls("collections.Sequence_TCollection_AsciiString", "TColStd.TColStd_SequenceOfAsciiString")
    lengths, angles, solid = Seq(), Seq(), Seq()
    reader.FileUnits(lengths, angles, solid)
    names = [lengths.Value(i).ToCString() for i in range(1, lengths.Length() + 1)]
    for n in names:
        if n.strip().lower() in _UNIT_NAMES:
            return _UNIT_NAMES[n.strip().lower()]
    return "mm", 1.0  # none given or unknown: OCCT's millimetres


def _unit_from_iges(gs) -> tuple[str, float]:
    flag = int(gs.UnitFlag())
    if flag in _IGES_UNIT_FLAGS:
        return _IGES_UNIT_FLAGS[flag]
    try:
        word = gs.UnitName().ToCString().strip().upper()
    except Exception:
        word = ""
    if word in _IGES_UNIT_WORDS:
        return _UNIT_NAMES[_IGES_UNIT_WORDS[word]]
    return "mm", 1.0


def _load_shape(occ: _Occ, path: str, fmt: str):
    """(shape, units, mm_per_unit) of a file, lengths in the file's units."""
    name = Path(path).name
    done = occ.mod("IFSelect").IFSelect_ReturnStatus.IFSelect_RetDone
    if fmt == "step":
        reader = occ.mod("STEPControl").STEPControl_Reader()
        status = reader.ReadFile(path)
        if status != done:
            raise CadFileError(f"{name}: not a readable STEP file (Open CASCADE: {status.name})")
        units, factor = _unit_from_step(occ, reader)
        reader.SetSystemLengthUnit(factor)
    else:
        reader = occ.mod("IGESControl").IGESControl_Reader()
        status = reader.ReadFile(path)
        if status != done:
            raise CadFileError(f"{name}: not a readable IGES file (Open CASCADE: {status.name})")
        model = reader.IGESModel()
        gs = model.GlobalSection()
        units, factor = _unit_from_iges(gs)
        gs.SetCascadeUnit(factor)
        model.SetGlobalSection(gs)
    if reader.NbRootsForTransfer() == 0:
        raise CadFileError(f"{name}: the file holds no shapes")
    reader.TransferRoots()
    shape = reader.OneShape()
    if shape.IsNull():
        raise CadFileError(f"{name}: no shape could be made from the file")
    return shape, units, factor


def _faces(occ: _Occ, shape) -> list:
    TopExp_Explorer = occ.mod("TopExp").TopExp_Explorer
    face_type = occ.mod("TopAbs").TopAbs_ShapeEnum.TopAbs_FACE
    as_face = occ.static("TopoDS", "TopoDS", "Face")
    out = []
    ex = TopExp_Explorer(shape, face_type)
    while ex.More():
        out.append(as_face(ex.Current()))
        ex.Next()
    return out


def _occ_read(path: str, fmt: str, chord_tol: float) -> dict:
    """Everything the caller needs from a file, as plain data (runs in the child)."""
    occ = _Occ()
    name = Path(path).name
    shape, units, factor = _load_shape(occ, path, fmt)
    originals = _faces(occ, shape)
    if not originals:
        raise CadFileError(f"{name}: the file has no faces (no surfaces to cover)")
    NurbsConvert = occ.mod("BRepBuilderAPI").BRepBuilderAPI_NurbsConvert
    try:
        faces = _faces(occ, NurbsConvert(shape, True).Shape())
    except Exception:  # OCCT refuses some faces (e.g. a periodic B-spline
        faces = None   # face across its knot range's end): convert the faces one by one
    if faces is not None and len(faces) != len(originals):
        faces = None
    data = []
    for index, orig in enumerate(originals):
        try:
            face = faces[index] if faces is not None else _convert_one(occ, orig)
            data.append(_face_data(occ, index, orig, face, chord_tol))
        except CadFileError as exc:
            raise CadFileError(f"{name}: face {index}: {exc}") from None
    return {"units": units, "mm_per_unit": factor, "faces": data}


def _convert_one(occ: _Occ, face):
    """One face converted to NURBS; a face that OCCT cannot convert but whose
    surface is already a B-spline or a Bezier patch is used as it is."""
    try:
        converted = _faces(occ, occ.mod("BRepBuilderAPI").BRepBuilderAPI_NurbsConvert(face, True).Shape())
        if len(converted) == 1:
            return converted[0]
    except Exception:
        pass
    kind = _surface_kind(occ, face)
    if kind in ("bspline", "bezier"):
        return face
    raise CadFileError(f"Open CASCADE cannot convert the {kind} face to NURBS")


def _surface_kind(occ: _Occ, face) -> str:
    adaptor = occ.mod("BRepAdaptor").BRepAdaptor_Surface(face, False)
    return _KINDS.get(adaptor.GetType().name, "other")


def _face_area(occ: _Occ, face) -> float:
    props = occ.mod("GProp").GProp_GProps()
    occ.static("BRepGProp", "BRepGProp", "SurfaceProperties")(face, props, 1e-10)
    return float(props.Mass())


def _bspline(occ: _Occ, face, uv_box, kind: str) -> dict:
    """The face's surface as arrays of a non-periodic B-spline whose domain
    holds uv_box. A periodic direction has its origin moved to where the
    face's loops start when they cross the knot range's end, and its knots
    shifted by whole periods when the loops lie periods away."""
    Geom_BSplineSurface = occ.mod("Geom").Geom_BSplineSurface
    s = occ.static("BRep", "BRep_Tool", "Surface")(face)
    if hasattr(s, "BasisSurface") and not isinstance(s, Geom_BSplineSurface):
        s = s.BasisSurface()  # a rectangular trimmed surface
    if not isinstance(s, Geom_BSplineSurface):
        try:
            s = occ.static("GeomConvert", "GeomConvert", "SurfaceToBSplineSurface")(s)
        except Exception:
            s = None
        if not isinstance(s, Geom_BSplineSurface):
            raise CadFileError(f"the {kind} surface could not be converted to NURBS")
    s = s.Copy()  # the shape's own surface stays as it is (OCP gives the copy its own type)
    if not isinstance(s, Geom_BSplineSurface):
        raise CadFileError(f"the copy of the {kind} surface is not a B-spline")
    shifts = {}
    for d, lo, hi in (("U", uv_box[0], uv_box[1]), ("V", uv_box[2], uv_box[3])):
        shifts[d] = 0.0
        if not getattr(s, f"Is{d}Periodic")():
            continue
        knot = getattr(s, f"{d}Knot")
        first, last = knot(1), knot(getattr(s, f"Nb{d}Knots")())
        period = last - first
        eps = 1e-9 * max(1.0, abs(period))
        if hi - lo > period + eps:
            raise CadFileError(f"the face's loops span more than one period of its {kind} surface")
        k = np.floor((lo - first + eps) / period)
        lo_n, hi_n = lo - k * period, hi - k * period
        if hi_n > last + eps:  # the loops cross the end of the knot range: start it at lo_n
            getattr(s, f"Insert{d}Knot")(lo_n, 1, eps, False)
            n = getattr(s, f"Nb{d}Knots")()
            idx = 1 + int(np.argmin([abs(knot(i) - lo_n) for i in range(1, n + 1)]))
            getattr(s, f"Set{d}Origin")(idx)
        getattr(s, f"Set{d}NotPeriodic")()
        shifts[d] = float(k * period)
    out = _surface_arrays(s)
    out["knots_u"] = out["knots_u"] + shifts["U"]
    out["knots_v"] = out["knots_v"] + shifts["V"]
    return out


def _full_knots(values, mults) -> np.ndarray:
    return np.repeat(np.asarray(values, float), np.asarray(mults, int))


def _surface_arrays(s) -> dict:
    nu, nv = s.NbUPoles(), s.NbVPoles()
    rational = bool(s.IsURational() or s.IsVRational())
    P = np.empty((nu, nv, 3))
    W = np.ones((nu, nv))
    for i in range(nu):
        for j in range(nv):
            p = s.Pole(i + 1, j + 1)
            P[i, j] = (p.X(), p.Y(), p.Z())
            if rational:  # (OCCT 7.9 answers 0 for a polynomial surface made non-periodic)
                W[i, j] = s.Weight(i + 1, j + 1)
    ku = _full_knots([s.UKnot(i) for i in range(1, s.NbUKnots() + 1)],
                     [s.UMultiplicity(i) for i in range(1, s.NbUKnots() + 1)])
    kv = _full_knots([s.VKnot(i) for i in range(1, s.NbVKnots() + 1)],
                     [s.VMultiplicity(i) for i in range(1, s.NbVKnots() + 1)])
    return {"degree_u": int(s.UDegree()), "degree_v": int(s.VDegree()), "knots_u": ku, "knots_v": kv,
            "ctrlpts": P, "weights": W}


def _curve_points(curve, ts: np.ndarray) -> np.ndarray:
    out = np.empty((len(ts), 2))
    for k, t in enumerate(ts):
        p = curve.Value(float(t))
        out[k] = (p.X(), p.Y())
    return out


def _sample_curve(occ: _Occ, curve, t0: float, t1: float, tol: float, straight: bool):
    """(parameters, points) of a 2D curve from t0 to t1 (both kept),
    adaptively: until every chord's midpoint parameter is within tol of the
    chord; points on a straight run are dropped."""
    if straight:
        ts = np.array([t0, t1])
        return ts, _curve_points(curve, ts)
    basis = curve
    while hasattr(basis, "BasisCurve"):
        basis = basis.BasisCurve()
    n0 = 16
    if hasattr(basis, "NbKnots"):
        n0 = max(n0, 4 * int(basis.NbKnots()))
    ts = np.linspace(t0, t1, min(n0, 4096) + 1)
    pts = _curve_points(curve, ts)
    for _ in range(30):
        tm = 0.5 * (ts[:-1] + ts[1:])
        pm = _curve_points(curve, tm)
        a, b = pts[:-1], pts[1:]
        chord = b - a
        length = np.hypot(chord[:, 0], chord[:, 1])
        rel = pm - a
        cross = np.abs(chord[:, 0] * rel[:, 1] - chord[:, 1] * rel[:, 0])
        dist = np.where(length > 0, cross / np.where(length > 0, length, 1.0), np.hypot(rel[:, 0], rel[:, 1]))
        split = dist > tol
        if not np.any(split) or len(ts) > 200_000:
            break
        ts = np.insert(ts, np.nonzero(split)[0] + 1, tm[split])
        pts = np.insert(pts, np.nonzero(split)[0] + 1, pm[split], axis=0)
    keep = _drop_collinear(pts, 1e-3 * tol)
    return ts[keep], pts[keep]


def _drop_collinear(pts: np.ndarray, eps: float) -> np.ndarray:
    """Indices of the points to keep: the two ends alone when every point lies
    within eps of the chord between them, in order (a straight B-spline
    pcurve, as the NURBS conversion makes of lines); all of them otherwise."""
    if len(pts) <= 2:
        return np.arange(len(pts))
    a, d = pts[0], pts[-1] - pts[0]
    length = float(np.hypot(*d))
    if length > 0:
        rel = pts - a
        dist = np.abs(d[0] * rel[:, 1] - d[1] * rel[:, 0]) / length
        along = rel @ d / length**2
        if np.all(dist <= eps) and np.all(np.diff(along) > 0):
            return np.array([0, len(pts) - 1])
    return np.arange(len(pts))


def _wire_loop(occ: _Occ, wire, face, tol: float) -> tuple[np.ndarray, np.ndarray, float, float]:
    """(points, breaks, max edge tolerance, max trim deviation) of one wire
    of face, in (u, v)."""
    curve_on_surface = occ.static("BRep", "BRep_Tool", "CurveOnSurface")
    edge_range = occ.static("BRep", "BRep_Tool", "Range")
    tolerance = occ.static("BRep", "BRep_Tool", "Tolerance")
    degenerated = occ.static("BRep", "BRep_Tool", "Degenerated")
    reversed_ = occ.mod("TopAbs").TopAbs_Orientation.TopAbs_REVERSED
    Line = occ.mod("Geom2d").Geom2d_Line
    ex = occ.mod("BRepTools").BRepTools_WireExplorer(wire, face)
    pieces, max_tol, max_dev = [], 0.0, 0.0
    while ex.More():
        edge = ex.Current()
        max_tol = max(max_tol, float(tolerance(edge)))
        curve = curve_on_surface(edge, face, 0.0, 0.0)
        if curve is None:
            fix = occ.mod("ShapeFix").ShapeFix_Edge()
            fix.FixAddPCurve(edge, face, False)
            curve = curve_on_surface(edge, face, 0.0, 0.0)
            if curve is None:
                raise CadFileError("an edge has no curve on the face")
        t0, t1 = edge_range(edge, face)
        basis = curve
        while hasattr(basis, "BasisCurve"):
            basis = basis.BasisCurve()
        ts, pts = _sample_curve(occ, curve, t0, t1, tol, isinstance(basis, Line) or bool(degenerated(edge)))
        if not degenerated(edge):
            spans = int(basis.NbKnots()) if hasattr(basis, "NbKnots") else 1
            check = np.union1d(ts, np.linspace(t0, t1, max(65, 8 * spans + 1)))
            max_dev = max(max_dev, _edge_deviation(occ, edge, face, curve, check))
        if edge.Orientation() == reversed_:
            pts = pts[::-1]
        pieces.append(pts)
        ex.Next()
    if not pieces:
        raise CadFileError("a wire of the face has no edges")
    starts = np.cumsum([0] + [len(p) - 1 for p in pieces[:-1]])
    loop = np.vstack([p[:-1] for p in pieces])
    return loop, starts, max_tol, max_dev


def _edge_deviation(occ: _Occ, edge, face, pcurve, ts: np.ndarray) -> float:
    """Largest distance between the edge's 3D curve and its curve on the face
    at the parameters ts (BRepCheck's same-parameter measure, at more
    points); 0 when the edge has no 3D curve."""
    c3 = occ.static("BRep", "BRep_Tool", "Curve")(edge, 0.0, 0.0)
    if c3 is None:
        return 0.0
    s = occ.static("BRep", "BRep_Tool", "Surface")(face)
    worst = 0.0
    for t in ts:
        q = pcurve.Value(float(t))
        worst = max(worst, s.Value(q.X(), q.Y()).Distance(c3.Value(float(t))))
    return float(worst)


def _wires(occ: _Occ, face, kind: str) -> list:
    """The face's wires, the outer one first."""
    outer = occ.static("BRepTools", "BRepTools", "OuterWire")(face)
    if outer.IsNull():
        raise CadFileError(f"the {kind} face has no boundary")
    wires = [outer]
    it = occ.mod("TopoDS").TopoDS_Iterator(face)
    as_wire = occ.static("TopoDS", "TopoDS", "Wire")
    wire_type = occ.mod("TopAbs").TopAbs_ShapeEnum.TopAbs_WIRE
    while it.More():
        w = it.Value()
        if w.ShapeType() == wire_type and not w.IsSame(outer):
            wires.append(as_wire(w))
        it.Next()
    return wires


def _face_data(occ: _Occ, index: int, orig, face, chord_tol: float) -> dict:
    kind = _surface_kind(occ, orig)
    reversed_ = face.Orientation() == occ.mod("TopAbs").TopAbs_Orientation.TopAbs_REVERSED
    uv_box = tuple(occ.static("BRepTools", "BRepTools", "UVBounds")(face))
    tol = chord_tol * max(float(np.hypot(uv_box[1] - uv_box[0], uv_box[3] - uv_box[2])), 1e-300)
    loops, breaks = [], []
    max_tol = float(occ.static("BRep", "BRep_Tool", "Tolerance")(face))
    max_dev = 0.0
    for w in _wires(occ, face, kind):
        p, b, t, dev = _wire_loop(occ, w, face, tol)
        loops.append(p)
        breaks.append(b)
        max_tol, max_dev = max(max_tol, t), max(max_dev, dev)
    surface = _bspline(occ, face, uv_box, kind)
    return {"index": index, "kind": kind, "reversed": bool(reversed_), "area": _face_area(occ, orig),
            "tolerance": max_tol, "trim_deviation": max_dev, "loops": loops, "breaks": breaks,
            "uv_box": uv_box, **surface}


def _occ_tessellate(path: str, fmt: str, indices: list, linear: float, angular: float) -> dict:
    """Triangles of the faces ``indices`` (runs in the child): per face its
    nodes (n, 3) with the placement applied, triangles (m, 3) wound along
    the face's normal, and per edge its id in the whole shape with the
    indices of the nodes on it, in the edge's parameter order (the faces
    sharing an edge have as many nodes on it, at the same parameters)."""
    occ = _Occ()
    name = Path(path).name
    shape, units, factor = _load_shape(occ, path, fmt)
    originals = _faces(occ, shape)
    for i in indices:
        if not 0 <= i < len(originals):
            raise CadFileError(f"{name}: face index {i} is out of range (0 to {len(originals) - 1})")
    edge_type = occ.mod("TopAbs").TopAbs_ShapeEnum.TopAbs_EDGE
    IndexedMap = occ.cls("collections.IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher",
                         "collections.IndexedMap_TopoDS_Shape", "TopTools.TopTools_IndexedMapOfShape")
    edge_ids = IndexedMap()
    occ.static("TopExp", "TopExp", "MapShapes")(shape, edge_type, edge_ids)
    builder = occ.mod("BRep").BRep_Builder()
    compound = occ.mod("TopoDS").TopoDS_Compound()
    builder.MakeCompound(compound)
    for i in indices:
        builder.Add(compound, originals[i])
    occ.static("BRepTools", "BRepTools", "Clean")(compound)  # a triangulation the file brought: made anew
    mesher = occ.mod("BRepMesh").BRepMesh_IncrementalMesh(compound, float(linear), False, float(angular), False)
    if not mesher.IsDone():
        raise CadFileError(f"{name}: Open CASCADE could not tessellate faces {indices}")
    triangulation = occ.static("BRep", "BRep_Tool", "Triangulation")
    on_triangulation = occ.static("BRep", "BRep_Tool", "PolygonOnTriangulation")
    as_edge = occ.static("TopoDS", "TopoDS", "Edge")
    reversed_ = occ.mod("TopAbs").TopAbs_Orientation.TopAbs_REVERSED
    Location = occ.mod("TopLoc").TopLoc_Location
    out = []
    for i in indices:
        face = originals[i]
        loc = Location()
        tri = triangulation(face, loc)
        if tri is None or tri.NbTriangles() == 0:
            raise CadFileError(f"{name}: Open CASCADE made no triangles of face {i}")
        trsf = None if loc.IsIdentity() else loc.Transformation()
        nodes = np.empty((tri.NbNodes(), 3))
        for k in range(tri.NbNodes()):
            q = tri.Node(k + 1)
            if trsf is not None:
                q = q.Transformed(trsf)
            nodes[k] = (q.X(), q.Y(), q.Z())
        tris = np.array([tri.Triangle(k + 1).Get() for k in range(tri.NbTriangles())], dtype=np.int64) - 1
        normals = None
        try:  # the surface's normals at the nodes: densify lifts new points off the chords with them
            occ.static("BRepLib", "BRepLib_ToolTriangulatedShape", "ComputeNormals")(face, tri)
            normals = np.empty((tri.NbNodes(), 3))
            for k in range(tri.NbNodes()):
                d = tri.Normal(k + 1)
                if trsf is not None:
                    d = d.Transformed(trsf)
                normals[k] = (d.X(), d.Y(), d.Z())
        except Exception:  # an OCCT without it: the new points stay on the chords
            normals = None
        if face.Orientation() == reversed_:
            tris = tris[:, ::-1].copy()
        edges = []
        ex = occ.mod("TopExp").TopExp_Explorer(face, edge_type)
        while ex.More():
            edge = as_edge(ex.Current())
            poly = on_triangulation(edge, tri, loc)
            if poly is not None:
                edges.append((int(edge_ids.FindIndex(edge)),
                              np.array([poly.Node(k + 1) for k in range(poly.NbNodes())], dtype=np.int64) - 1))
            ex.Next()
        out.append({"index": i, "kind": _surface_kind(occ, face), "area": _face_area(occ, face),
                    "nodes": nodes, "triangles": tris, "normals": normals, "edges": edges})
    return {"units": units, "mm_per_unit": factor, "faces": out}


if __name__ == "__main__":  # the child process of run_child: python -I -m flatweave.reading.cad ...
    _child_main(sys.argv[1:])
