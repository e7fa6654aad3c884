"""The headless command line: ``python -m flatweave`` (also installed as ``flatweave-cli``).

Subcommands:

* ``flatten SURFACE --spacing R ... --out RESULT.json``: drape, minimise, write the result
* ``sweep SURFACE --spacing R [--angles K] [--seeds M] [--out SWEEP.json]``: solve at
  several weft angles (and seeds), print the ranked table (:mod:`flatweave.studies.sweep`)
* ``info SURFACE``: domain, area and boundary length of a surface
* ``examples``: the bundled example surfaces

SURFACE is a surface file (any format of :mod:`flatweave.reading.registry`) or the name of a
bundled example; the export formats are those of :mod:`flatweave.export.registry`. Errors a
user can cause print one line, ``flatweave: error: ...``, and exit with status 2.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
import time
import traceback
import warnings
from pathlib import Path

import numpy as np

from flatweave.errors import FlatweaveError, SettingsError
from flatweave.reading.registry import open_path
from flatweave.reading.cad import is_cad_path, parse_face_list
from flatweave.reading.cadjoin import join_faces
from flatweave.reading.meshes import is_mesh_path, mesh_to_cut, panel_advice, units_note
from flatweave.reading.registry import readers
from flatweave.export.registry import exporter_for, exporters
from flatweave.method.solvers import DEFAULT_SOLVER, method_help, method_names, solver_help, solver_names
from flatweave.method.energy import parse_yarn
from flatweave.method.darts import PlaneDart
from flatweave.files import check_output, exists, json_bytes, parse_json, read_input, same_file, write_json
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import flatten, state_from_dict
from flatweave.method.result import result_to_dict
from flatweave.document.sewing import piece_sheet, seam_line_from_spec, sew
from flatweave.version import __version__
from flatweave.geometry.quadrature import region_area
from flatweave.export.registry import (MAX_SEAM_MM, ExportOption, ExportOptions, check_target, export_files,
                                       export_options, option_formats, surprises)
from flatweave.export.sheet import UNITS, join_sheets
from flatweave.geometry.region import cover_for
from flatweave.method.lattice import parse_material
from flatweave.studies.planar import PlanarSettings, flatten_planar, planar_result_to_dict
from flatweave.method.solvers import solver_entry
from flatweave.studies.sweep import sweep
from flatweave.document.project import PROJECT_SUFFIX, Project, project_to_dict
from flatweave.document.recovery import save_with_backups
from flatweave.document.matching import solve_all
from flatweave.document import cutplan
from flatweave.document.cutsettings import CutPlanSettings, part_of
from flatweave.document.project import load_project, result_from_dict
from flatweave.export.marker import MARKER_FORMATS, marker_files
from flatweave.studies.nesting import DEFAULT_SECONDS, ROTATIONS, nest
from flatweave.document.checks import project_checks, seam_rows, seam_warnings
from flatweave.document.cutfiles import check_folder, export_pieces, file_stem
from flatweave.document.plybook import plybook_bytes
from flatweave.files import atomic_write_many
from flatweave.document.pieces import index_of
from flatweave.document.rosettes import orientation_text
from flatweave.reading.jobs import JOB_SUFFIX
from flatweave.geometry.quadrature import boundary_length
from flatweave.reading.examples import example_path, job_names, job_path, list_examples
from flatweave.geometry.region import region_from_spec
from flatweave.method.darts import curve_dart_from_file
from flatweave.geometry.region import check_region_size
from flatweave.studies.autodarts import suggest_darts
from flatweave.reading.cad import cad_info
from flatweave.geometry import meshfit
from flatweave.geometry.meshfit import FitTolerance, SeveralParts, boundary_loops, clean_mesh, edge_table
from flatweave.geometry.meshfit import open_ends
from flatweave.geometry.region import offset_region

__all__ = ["main", "build_parser"]


def _floats(text: str, n: int, what: str) -> tuple[float, ...]:
    try:
        values = tuple(float(x) for x in text.split(","))
    except ValueError:
        values = ()
    if len(values) != n:
        raise SettingsError(f"{what} {text!r} must be {n} comma-separated numbers")
    return values


def resolve_surface(name: str):
    """Load a surface from a path or a bundled example's name; returns (surface, source).
    A project file is refused: these commands take a surface."""

    opened = open_path(name, surface_only=True).choose_face()
    return opened.surface, opened.source


def reader_region(name: str) -> bool:
    """Whether the surface file's chosen face is trimmed."""

    return open_path(name, surface_only=True).choose_face().region is not None


def resolve_piece(args):
    """The Opened surface of ``args.surface`` with its face (``--face``) and
    region (a CAD face's trims, or ``--region FILE.json``) chosen."""

    faces = _face_list(args)  # before the file is read: a bad list is refused at once
    tolerance = _fit_tolerance(args)
    seam = getattr(args, "seam", None)
    if isinstance(seam, list):  # flatten's: repeatable (panels on a surface); a mesh opens along one
        if len(seam) > 1 and is_mesh_path(args.surface):
            raise SettingsError(f"{Path(args.surface).name}: a mesh opens along one seam (--seam once); panels "
                                f"split by seams are for surfaces")
        seam = seam[0] if seam and is_mesh_path(args.surface) else None
    if seam and args.region:
        raise SettingsError("a region drawn on a mesh is one piece already; a seam is for a tube-shaped mesh "
                            "covered whole (give --region or --seam, not both)")
    if (args.region or seam) and is_mesh_path(args.surface) and Path(args.surface).is_file():
        opened = mesh_to_cut(args.surface)  # the drawn piece or seam: the whole mesh is never fitted as it is
    else:
        opened = open_path(args.surface, surface_only=True)
    if tolerance is not None and opened.mesh is None and faces is None:
        raise SettingsError(f"{Path(args.surface).name}: --fit-tolerance is for meshes (a surface file is "
                            f"the surface itself)")
    if args.region and opened.mesh is not None:  # a loop drawn on a mesh (open, closed, or of several parts)
        return _mesh_piece(args, opened, args.region, "region", opened.mesh.cut_spec, tolerance)
    if seam:
        if opened.mesh is None:
            raise SettingsError(f"{Path(args.surface).name}: here --seam opens a mesh (STL, OBJ, PLY, OFF) shaped "
                                f"like a tube; seams splitting a surface into panels are for flatten")
        return _mesh_piece(args, opened, seam, "seam", opened.mesh.seam_spec, tolerance)
    if faces is not None:
        opened = _join_faces(args, opened, faces)
    else:
        opened = opened.choose_face(args.face)
    if opened.mesh is not None and tolerance is not None:  # refitted to the tolerance stated
        opened = opened.refitted(tolerance)
    if opened.mesh is not None:  # a mesh (or one part of it) flattened whole, as asked, if badly
        mesh = getattr(opened.surface, "mesh", None)
        ends = open_ends(mesh.vertices, mesh.triangles) if mesh is not None else 1
        advice = panel_advice(Path(args.surface).name, getattr(opened.surface, "fit", None), ends)
        how = "--seam with a seam3d drawn on it opens it; " if ends >= 2 else ""
        if advice:
            opened = dataclasses.replace(
                opened, notes=opened.notes + (f"{advice} ({how}--region with a loop3d drawn on it cuts a panel out)",))
    offset = getattr(args, "region_offset", None)
    if args.region:

        if opened.region is not None:
            raise SettingsError(f"face {opened.face} of {Path(args.surface).name} is trimmed already; "
                                f"--region is for untrimmed surfaces")
        data = _read_json(args.region, "region")
        try:
            region = region_from_spec(opened.surface, data, offset=offset)
        except SettingsError as exc:
            raise SettingsError(f"{args.region}: {exc}") from None
        opened = dataclasses.replace(opened, region=region)
    elif offset:  # a trimmed face's region, or the whole domain, moved along the surface
        opened = dataclasses.replace(opened, region=offset_region(opened.surface, opened.region, offset))
    return opened


def _mesh_piece(args, opened, path: str, what: str, cut, tolerance):
    """``opened`` with the piece ``cut(spec, part, tolerance)`` makes of its mesh from the JSON
    file ``path`` (a ``--region`` or ``--seam``); its refusals name the file."""
    data = _read_json(path, what)
    try:
        piece = cut(data, args.face, tolerance)
    except FitTolerance:
        raise
    except SettingsError as exc:
        raise SettingsError(f"{path}: {exc}") from None
    return dataclasses.replace(opened, surface=piece.surface, region=piece.region, face=args.face)


def _fit_tolerance(args) -> float | None:
    """``--fit-tolerance T`` (model units), or None without it."""
    return getattr(args, "fit_tolerance", None)  # finite and positive: its option's type (LENGTH)


def _face_list(args):
    """``--faces 2,5,7`` as (2, 5, 7), or None without it; refused with ``--face``."""
    text = getattr(args, "faces", None)
    if text is None:
        return None

    if getattr(args, "face", None) is not None:
        raise SettingsError("give --face N for one face or --faces A,B,... to join several, not both")
    if getattr(args, "region", None):
        raise SettingsError("the region of joined faces is their outline; --region is for untrimmed surfaces "
                            "(drop --faces or --region)")
    if not is_cad_path(args.surface):
        raise SettingsError(f"{Path(args.surface).name}: --faces is for STEP and IGES files")
    return parse_face_list(text)


def _join_faces(args, opened, indices):
    """``--faces 2,5,7``: those faces of a STEP or IGES file joined into one
    surface by the mesh route (:func:`flatweave.reading.cadjoin.join_faces`)."""
    if opened.cad is None:
        raise SettingsError(f"{Path(args.surface).name}: --faces is for STEP and IGES files")
    piece = join_faces(opened.cad, indices, tolerance=_fit_tolerance(args))
    return dataclasses.replace(opened, surface=piece.surface, region=piece.region, face=None)


def _help(text: str) -> str:
    return text.replace("%", "%%")  # argparse formats help with %


def _surface_help() -> str:
    files = "; ".join(f"{', '.join(r.suffixes)}: {r.description}" for r in readers(project=False))
    return _help(f"surface file ({files}) or bundled example name")


# Export options whose default the command takes from the file, not from the declaration.
_FILE_DEFAULTS = {"units": "a STEP or IGES file's own, a mesh's guessed from its size, else m",
                  "name": "the surface's name"}


def _add_export_option(parser, option: ExportOption) -> None:
    """The flag of one declared export option (its value is None when not given)."""
    default = _FILE_DEFAULTS.get(option.name, f"{option.default:g}" if option.kind == "number" else option.default)
    kw = dict(dest=option.name, default=None,
              help=f"{option.help} ({' '.join(option_formats(option.name))}; default {default})")
    if option.kind == "number":
        kw.update(type=_number(option.minimum, min(option.maximum, 1e15)), metavar=option.unit.upper() or "X")
    elif option.kind == "choice":
        kw.update(choices=list(option.choices))
    else:
        kw.update(metavar="TEXT")
    parser.add_argument(option.cli_flag, **kw)


def _units_taken(args, opened) -> str | None:
    """The one-line note that a mesh's units were guessed (never silently
    metres), or None when --units is given or the file says its units."""
    fit = getattr(opened.surface, "fit", None)
    if args.units is not None or opened.cad is not None or opened.units_guess is None or fit is None:
        return None
    return f"{units_note(Path(args.surface).name, float(fit.size), opened.units_guess)}; give --units to choose"


def _export_values(args, opened) -> dict:
    """The export options given on the command line, with the file's units and name where not given."""
    values = {o.name: getattr(args, o.name) for o in export_options() if getattr(args, o.name, None) is not None}
    if "units" not in values:
        units = opened.units if opened.cad is not None else opened.units_guess or "m"
        if units not in UNITS:
            raise SettingsError(f"{Path(args.surface).name} is in {units}; exports take {', '.join(UNITS)}: "
                                f"give --units")
        values["units"] = units
    values.setdefault("name", Path(args.surface).stem)
    return values


def _export_help() -> str:
    formats = "; ".join(f"{e.suffix} ({e.description})" for e in exporters())
    return _help(f"write the pattern to PATH, the suffix picks the format: {formats}; repeatable")


class OneLineParser(argparse.ArgumentParser):
    """argparse's parser whose refusals are one line naming the option, not the
    usage block (subcommands' parsers are of this class too; the window's
    launcher, :mod:`flatweave.app.main`, uses it as well)."""

    def error(self, message):
        command = self.prog.removeprefix("python -m flatweave").strip()
        command = "" if command == self.prog else command
        where = f"{command}: " if command else ""
        self.exit(2, f"flatweave: error: {where}{message}; see {self.prog} --help\n")


def build_parser() -> argparse.ArgumentParser:
    p = OneLineParser(
        prog="python -m flatweave",
        description="flatweave: flat patterns of woven fabric or isotropic sheets covering NURBS surfaces.")
    p.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    exact = {"allow_abbrev": False}  # no option is read as a longer one (--face is never --faces)

    f = sub.add_parser("flatten", **exact, help="drape a spring mesh on a surface, minimise it, write the result")
    f.add_argument("surface", metavar="SURFACE", help=_surface_help())
    f.add_argument("--method", choices=method_names(), default="spring", help=method_help())
    f.add_argument("--spacing", type=LENGTH, required=True, metavar="R",
                   help="rest length of the weft springs (and of the warp springs unless --spacing-warp)")
    f.add_argument("--spacing-warp", type=LENGTH, default=None, metavar="R", help="rest length of the warp springs")
    f.add_argument("--material", default="woven", metavar="NAME",
                   help="woven (500:500:1), isotropic (100:100:50), paper-isotropic (the paper's 100:100:100) "
                        "or a ratio WEFT:WARP:DIAG (default woven)")
    f.add_argument("--shear-angles", default=None, metavar="WARN,LOCK",
                   help="the material's shear warning and lock angles, degrees (default the preset's, 15,30)")
    f.add_argument("--seed", default=None, metavar="U,V",
                   help="seed point as fractions of the parameter domain (default 0.5,0.5; on a trimmed "
                        "piece the point farthest from its edge)")
    f.add_argument("--face", type=FACE, default=None, metavar="N",
                   help="the face of a STEP or IGES file to flatten (needed when it has several; "
                        "'info FILE' lists them)")
    f.add_argument("--faces", default=None, metavar="A,B,...",
                   help="join adjacent faces of a STEP or IGES file into one surface (tessellated, welded "
                        "along their shared edges and fitted as a mesh), so that a piece can cross a fillet")
    f.add_argument("--fit-tolerance", type=LENGTH, default=None, metavar="T",
                   help="a mesh (or --faces): refine the fitted surface until no vertex is farther than T "
                        "(model units) from it, or say in one line why it cannot be (default 0.02 %% of the "
                        "piece's size, as near as the mesh's vertices allow)")
    f.add_argument("--region", default=None, metavar="REGION.json",
                   help='cover only a region of the surface: drawn, {"points": [[x, y, z], ...], '
                        '"view_direction": [dx, dy, dz]} (projected as curve darts are), or {"uv": [[s, t], '
                        '...]} (fractions of the domain), or {"outer": [[u, v], ...]} (domain coordinates); '
                        'each with optional "holes": [loop, ...] in the same form')
    f.add_argument("--seam", action="append", default=[], metavar="SEAM.json",
                   help='on a surface: a seam line that splits it (or its region) into panels, each flattened, '
                        'their sew lines matched; {"points": [[x, y, z], ...], "view_direction": [dx, dy, dz]} '
                        '(drawn, projected onto it) or {"uv": [[u, v], ...]}, optional "name", "closed", '
                        '"allowance_mm" (its own seam allowance), "notches" ([[u, v], ...] on it), "matched" '
                        '(true: its two sides solved to equal lengths); from edge to edge, edge to seam, or '
                        'closed; repeatable (--out NAME.flatweave keeps them). On a mesh shaped like a tube (a sleeve, '
                        'a leg, a pipe: open at two ends): open it along one seam drawn from one end to the other, '
                        '{"seam3d": [[x, y, z], ...]} (points on it) or the drawn form; the '
                        "pattern's two edges along the seam sew back together")
    f.add_argument("--notch-every", type=NOTCH_MM, default=0.0, metavar="MM",
                   help="with --seam on a surface: a notch on both panels every MM millimetres along each sew "
                        "line, besides its two ends (default 0: the ends only)")
    f.add_argument("--region-offset", type=OFFSET, default=None, metavar="D",
                   help="move the region's boundary (or the face's edge) by D along the surface, in model "
                        "units: positive outwards, negative inwards; clipped to the surface")
    f.add_argument("--angle", type=_angle, default=0.0, metavar="DEG|auto",
                   help="weft direction at the seed, degrees from the u direction (default 0); auto: the "
                        "best of a sweep (see the sweep command, refined to a quarter degree), recorded in the result")
    f.add_argument("--paths", choices=("plane", "geodesic"), default="plane",
                   help="constrained paths: the paper's normal-section planes or geodesics (default plane)")
    f.add_argument("--solver", choices=solver_names("spring"), default=DEFAULT_SOLVER, help=solver_help("spring"))
    f.add_argument("--tol", type=TOL, default=1e-9, metavar="T",
                   help="stop when an iteration lowers the energy by less than T times the energy (default 1e-9)")
    f.add_argument("--max-iter", type=ITERATIONS, default=1000, metavar="N", help="iteration budget (default 1000)")
    f.add_argument("--max-seconds", type=SECONDS, default=None, metavar="S", help="time budget of the solver")
    f.add_argument("--warm-start", metavar="RESULT.json", default=None,
                   help="start the solver from the nodes of an earlier result instead of a new drape")
    f.add_argument("--quiet", action="store_true", help="no progress on stderr")
    f.add_argument("--yarn", action="append", default=[], metavar="weft:I|warp:J|weft@X,Y,Z|warp@X,Y,Z",
                   help="hold a weft row I or warp column J, or the weft row or warp column through the "
                        "lattice node nearest the point (X, Y, Z) (found after the drape, so it stays the "
                        "same thread at any spacing), to --yarn-plane (repeatable)")
    f.add_argument("--yarn-plane", action="append", default=[], metavar="A,B,C,D",
                   help="plane A x + B y + C z + D = 0 for the matching --yarn")
    f.add_argument("--yarn-k", action="append", type=WEIGHT, default=[], metavar="K",
                   help="weight of the matching --yarn (default 1000)")
    f.add_argument("--plane-dart", action="append", default=[], metavar="A,B,C,D[:XMIN,XMAX,YMIN,YMAX,ZMIN,ZMAX]",
                   help="cut a plane dart: the plane A x + B y + C z + D = 0 inside the box (repeatable)")
    f.add_argument("--curve-dart", action="append", default=[], metavar="FILE.json",
                   help="cut a curve dart: a 3D polyline and a view direction (see README; repeatable)")
    f.add_argument("--auto-darts", type=AUTO_DARTS, default=0, metavar="N",
                   help="after the solve, add up to N suggested darts, from the edge inwards: none when every "
                        "metric is within its warning limit; each the best by the pattern's usability, then the "
                        "metrics past their limits, then the energy; never one that takes a metric past a limit "
                        "it was within or whose solve does not converge. Listed in the result's darts with "
                        "\"auto\": true")
    f.add_argument("--max-nodes", type=NODES, default=2_000_000, metavar="N",
                   help="refuse meshes estimated larger than N nodes, or than the available memory holds "
                        "(default 2,000,000)")
    f.add_argument("--out", metavar="RESULT.json", help="result file to write")
    f.add_argument("--export", action="append", default=[], metavar="PATH", help=_export_help())
    for option in export_options():  # every option a registered format declares
        _add_export_option(f, option)

    w = sub.add_parser("sweep", **exact,
                       help="solve at several weft angles (and seeds) and rank them: a usable pattern "
                            "(no metric past its bad limit) first, then area beyond the lock angle, "
                            "then max shear, then boundary error")
    w.add_argument("surface", metavar="SURFACE", help=_surface_help())
    w.add_argument("--spacing", type=LENGTH, required=True, metavar="R", help="rest length of the weft springs")
    w.add_argument("--spacing-warp", type=LENGTH, default=None, metavar="R", help="rest length of the warp springs")
    w.add_argument("--material", default="woven", metavar="NAME", help="as for flatten (default woven)")
    w.add_argument("--seed", default=None, metavar="U,V", help="the first seed (default as for flatten)")
    w.add_argument("--face", type=FACE, default=None, metavar="N", help="as for flatten")
    w.add_argument("--faces", default=None, metavar="A,B,...", help="as for flatten")
    w.add_argument("--region", default=None, metavar="REGION.json", help="as for flatten")
    w.add_argument("--seam", default=None, metavar="SEAM.json", help="as for flatten")
    w.add_argument("--fit-tolerance", type=LENGTH, default=None, metavar="T", help="as for flatten")
    w.add_argument("--angles", type=ANGLES, default=12, metavar="K",
                   help="weft angles, evenly over a period (90 degrees when weft and warp are alike, else 180; "
                        "default 12)")
    w.add_argument("--seeds", type=SEEDS, default=1, metavar="M",
                   help="seeds: the first, then points well inside the piece, far apart (default 1)")
    w.add_argument("--refine", action="store_true", help="narrow the best angle down to a quarter degree")
    w.add_argument("--lock-angle", type=LOCK, default=None, metavar="DEG",
                   help="shear lock angle of the cloth (default the material's, 30 for the presets)")
    w.add_argument("--workers", type=WORKERS, default=None, metavar="N",
                   help="solves at once, in worker processes (default: the number of cores, at most 4)")
    w.add_argument("--paths", choices=("plane", "geodesic"), default="plane", help="as for flatten")
    w.add_argument("--solver", choices=solver_names("spring"), default=DEFAULT_SOLVER, help=solver_help("spring"))
    w.add_argument("--tol", type=TOL, default=1e-9, metavar="T", help="as for flatten")
    w.add_argument("--max-iter", type=ITERATIONS, default=1000, metavar="N", help="as for flatten")
    w.add_argument("--plane-dart", action="append", default=[], metavar="A,B,C,D[:BOX]", help="as for flatten")
    w.add_argument("--curve-dart", action="append", default=[], metavar="FILE.json", help="as for flatten")
    w.add_argument("--out", metavar="SWEEP.json", help="write the ranked rows as JSON")
    w.add_argument("--quiet", action="store_true", help="no table on stdout")

    i = sub.add_parser("info", **exact, help="domain, area and boundary length of a surface; the faces of a CAD file")
    i.add_argument("surface", metavar="SURFACE", help=_surface_help())
    i.add_argument("--json", action="store_true",
                   help="print JSON (a STEP or IGES file: {\"units\": ..., \"faces\": [...]})")
    i.add_argument("--face", type=FACE, default=None, metavar="N",
                   help="a mesh of several parts: describe part N (0 = the largest); a STEP or IGES file: face N")
    i.add_argument("--faces", default=None, metavar="A,B,...",
                   help="a STEP or IGES file's faces joined as flatten --faces joins them: the piece and the fit")
    i.add_argument("--fit-tolerance", type=LENGTH, default=None, metavar="T",
                   help="as for flatten: the fit refined until no vertex is farther than T from the surface")

    sub.add_parser("examples", help="list the bundled example surfaces and jobs")

    v = sub.add_parser("solve", **exact, help="solve the pieces of a project (.flatweave) together, in worker "
                                              "processes, and save it with their results")
    v.add_argument("project", metavar="PROJECT.flatweave|JOB.toml",
                   help="a project saved by the window (or by solve), a job file (TOML: a laminate's plies), or a "
                        "bundled example job by name (flatweave-cli examples lists them)")
    v.add_argument("--piece", action="append", default=[], metavar="NAME",
                   help="solve this piece (repeatable; default every piece)")
    v.add_argument("--workers", type=WORKERS, default=None, metavar="N",
                   help="worker processes (default one per core, at most 4; never more than the available memory "
                        "holds; 1: one piece after another here)")
    v.add_argument("--dask", default=None, metavar="ADDRESS",
                   help="the scheduler's address of an existing Dask cluster, e.g. tcp://host:8786: the pieces are "
                        "solved on its workers instead of local processes (needs flatweave[cluster])")
    v.add_argument("--out", default=None, metavar="PROJECT.flatweave",
                   help="write the solved project here (default: over PROJECT, its old file kept as a backup; "
                        "a job's beside it, JOB.flatweave)")
    v.add_argument("--ply-book", default=None, metavar="BOOK.pdf",
                   help="also write the ply book: the stacking table, then a page per piece (the tool with the "
                        "piece, its fibres and numbers, its flat pattern at a stated scale)")
    v.add_argument("--export", default=None, metavar="DIR",
                   help="also write every solved piece's cut files into DIR (made if missing): one DXF with a block "
                        "per piece, an SVG and a tiled 1:1 PDF per piece, named by piece")
    v.add_argument("--seam-allowance", type=SEAM_MM, default=0.0, metavar="MM",
                   help="seam allowance of the cut files and the ply book's patterns, mm (default 0: a laminate's "
                        "plies are cut net)")
    v.add_argument("--notch-every", type=NOTCH_MM, default=0.0, metavar="MM",
                   help="the cut files of panels (pieces split by seams): a notch on both sides of each seam every "
                        "MM millimetres, besides its ends and the notches placed on it (default 0)")
    v.add_argument("--paper", default="a4", choices=["a4", "letter"], help="paper of the ply book and tiled PDFs")
    v.add_argument("--quiet", action="store_true", help="no table on stdout, no progress on stderr")

    n = sub.add_parser("nest", **exact, help="place every piece on a roll as short as can be (a marker), with "
                                             "sparrow's nesting engine, and export it")
    n.add_argument("inputs", nargs="+", metavar="INPUT[:QTY]",
                   help="a project (.flatweave: its solved pieces, each its quantity), a result file (flatten "
                        "--out: its pattern pieces) or a nesting instance (sparrow's or ESICUP's JSON, in mm); QTY "
                        "copies of each (default 1)")
    n.add_argument("--roll-width", type=ROLL_MM, default=None, metavar="W",
                   help="the roll's width in mm (default: the material's, from a project's cut plan or materials "
                        "table; an instance's strip height)")
    n.add_argument("--gap", type=GAP_MM, default=None, metavar="G",
                   help="the gap kept between pieces, mm (default a project's cut plan's, else 0); the options "
                        "below default to a project's cut plan too, when one project is nested")
    n.add_argument("--time-limit", type=NEST_SECONDS, default=None, metavar="S",
                   help=f"seconds the engine may take per marker (default {DEFAULT_SECONDS:g}; whole seconds)")
    n.add_argument("--rotations", choices=list(ROTATIONS), default=None,
                   help="how pieces may turn on the roll: grain (0 or 180 degrees, the warp along the roll), "
                        "one-way (0: a napped material), free (any: an isotropic sheet); default from each "
                        "piece's material (woven: grain, isotropic: free)")
    n.add_argument("--seam-allowance", type=SEAM_MM, default=None, metavar="MM",
                   help="the pieces' seam allowance, mm (default 0; a seam's own where it has one)")
    n.add_argument("--overlap", type=GAP_MM, default=None, metavar="MM",
                   help="a piece wider than the roll is spliced into parts that fit, by lines along the roll; the "
                        "parts overlap by MM at each splice (default 25, a composite ply's; a sewn seam's: twice "
                        "its allowance)")
    n.add_argument("--splice", action="append", default=[], metavar="NAME=MM[,MM...]",
                   help="splice piece NAME at these positions, mm across it from its edge (along the roll), in "
                        "place of the splices chosen for it (and of its project's); repeatable")
    n.add_argument("--mirror", action="append", default=[], metavar="NAME",
                   help="cut piece NAME in mirror pairs, a left and a right panel: of its copies, half are its "
                        "mirror image (an odd quantity has one more as drawn); repeatable; a project's cut plan "
                        "names its own")
    n.add_argument("--seed", type=NEST_SEED, default=0, metavar="N", help="the engine's random seed (default 0)")
    n.add_argument("--export", action="append", default=[], metavar="MARKER.dxf|.svg|.pdf|.csv",
                   help="write the marker (repeatable): DXF (a block per piece, placed per copy; the roll on "
                        "layer 15), SVG (1:1, mm), PDF (the whole marker at a round scale, then at 1:1 tiled over "
                        "A4 pages with overlap and registration marks), CSV (a row per placed copy); several "
                        "markers (materials) are written as NAME-MATERIAL.EXT")
    n.add_argument("--ply-book", default=None, metavar="BOOK.pdf",
                   help="with one project: also write its ply book, with a page per marker after the pieces' pages")
    n.add_argument("--paper", default="a4", choices=["a4", "letter"],
                   help="paper of the marker PDF's pages (its 1:1 tiles) and of the ply book")
    n.add_argument("--quiet", action="store_true", help="no progress on stderr")
    return p


def _number(lo: float, hi: float, whole: bool = False, above: bool = False):
    """An option's value type: a finite number from ``lo`` to ``hi`` (above ``lo`` when ``above``), a
    whole one when ``whole``; argparse names the option in the one-line refusal (issue 45, item 2)."""
    span = f"{'above' if above else 'from'} {lo:g} {'and at most' if above else 'to'} {hi:g}"
    kind = "a whole number" if whole else "a number"

    def parse(text: str):
        try:
            value = int(text) if whole else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r:.40} is not {kind} ({span})") from None
        if not math.isfinite(value) or value > hi or value < lo or (above and value == lo):
            raise argparse.ArgumentTypeError(f"{text!r:.40} is out of range: {kind} {span}")
        return value
    parse.__name__ = "whole number" if whole else "number"  # argparse's fallback message names the type
    return parse


# the ranges of the options' numbers (issue 45, item 2); a spacing and an offset are checked again
# against the piece's size once it is read
LENGTH = _number(0.0, 1e15, above=True)  # a length in model units (a spacing, a tolerance)
OFFSET = _number(-1e15, 1e15)
FACE = _number(0, 1_000_000, whole=True)
TOL = _number(0.0, 1.0, above=True)
ITERATIONS = _number(0, 10_000_000, whole=True)
SECONDS = _number(0.0, 1e7, above=True)
WEIGHT = _number(0.0, 1e12)
AUTO_DARTS = _number(0, 100, whole=True)
NODES = _number(1, 1_000_000_000, whole=True)
ANGLES = _number(1, 360, whole=True)
SEEDS = _number(1, 100, whole=True)
LOCK = _number(0.0, 90.0, above=True)
WORKERS = _number(1, 256, whole=True)
SEAM_MM = _number(0.0, MAX_SEAM_MM)
NOTCH_MM = _number(0.0, 1e6)
ROLL_MM = _number(0.0, 1e6, above=True)  # a roll's width, mm (a metre or two in practice)
GAP_MM = _number(0.0, 1e4)
NEST_SECONDS = _number(0.0, 24 * 3600.0, above=True)
NEST_SEED = _number(0, 2**63 - 1, whole=True)


def _angle(text: str):
    if text.strip().lower() == "auto":
        return "auto"
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is neither a number of degrees nor 'auto'") from None
    if not math.isfinite(value) or abs(value) > 1e6:
        raise argparse.ArgumentTypeError(f"{text!r:.40} is out of range: degrees from -1e+06 to 1e+06, or 'auto'")
    return value


def _yarns(args) -> tuple:
    if len(args.yarn_plane) != len(args.yarn):
        raise SettingsError(f"{len(args.yarn)} --yarn but {len(args.yarn_plane)} --yarn-plane: give one plane per yarn")
    if len(args.yarn_k) > len(args.yarn):
        raise SettingsError("more --yarn-k than --yarn")
    ks = list(args.yarn_k) + [1000.0] * (len(args.yarn) - len(args.yarn_k))
    return tuple(parse_yarn(y, pl, k) for y, pl, k in zip(args.yarn, args.yarn_plane, ks))


def _darts(args, surface) -> tuple:
    darts = []
    for k, spec in enumerate(args.plane_dart):
        plane, _, box = spec.partition(":")
        darts.append(PlaneDart(_floats(plane, 4, "plane dart"),
                               _floats(box, 6, "plane dart box") if box else None, name=f"plane dart {k + 1}"))
    for k, path in enumerate(args.curve_dart):

        darts.append(curve_dart_from_file(surface, path, name=f"curve dart {k + 1}"))
    return tuple(darts)


def _inputs(args) -> list[str]:
    """The files a command reads (its surface when it is a file, regions, darts, warm start, seam)."""
    seam = getattr(args, "seam", None)
    named = [getattr(args, "surface", None), getattr(args, "region", None), getattr(args, "warm_start", None),
             *(seam if isinstance(seam, list) else [seam]), *getattr(args, "curve_dart", [])]
    return [p for p in named if p and exists(p)]


def _check_outputs(args, outputs) -> None:
    """Refuse, before any work, an output that is one of the inputs (it would be overwritten) or
    that is not a regular file where one is (a device, a pipe: never replaced); one line each."""
    for path in outputs:
        check_output(path, SettingsError)
        for source in _inputs(args):
            if same_file(path, source):
                raise SettingsError(f"{path} is one of this run's inputs ({source}): write to another name")


def _cmd_flatten(args) -> int:
    if not args.out and not args.export:
        raise SettingsError("nothing to write: give --out RESULT.json and/or --export PATH")
    out = Path(args.out) if args.out else None
    if out is not None and out.parent and not out.parent.exists():
        raise SettingsError(f"cannot write {out}: folder {out.parent} does not exist")
    _check_outputs(args, [out] if out else [])
    if args.method == "planar":
        if args.export:
            raise SettingsError("--export writes spring-method patterns; drop it or use --method spring")
        if out is None:
            raise SettingsError("--method planar writes its result with --out RESULT.json")
        return _cmd_flatten_planar(args, out)
    # refuse bad export targets and options before the solve, not after it
    targets = [check_target(p) for p in args.export]
    _check_outputs(args, ([out] if out else []) + targets)
    opened = resolve_piece(args)
    options = ExportOptions.from_values(_export_values(args, opened))
    # warnings about the input: said at once (before a long solve) and kept in the result file
    notes = list(opened.notes) + [n for n in [_units_taken(args, opened)] if n]
    _print_warnings(notes)
    units = options.units
    surface, source, region = opened.surface, opened.source, opened.region

    cover = cover_for(surface, region)
    if opened.cad is not None and opened.face is not None:
        _check_face_size(opened, args.spacing)
    if region is not None:
        check_region_size(surface, region, args.spacing, args.spacing_warp)
    if args.seam and opened.mesh is None:  # seams on a surface: panels
        return _flatten_panels(args, opened, out, targets, notes, options)
    seed = _floats(args.seed, 2, "seed") if args.seed is not None else cover.default_seed
    settings = FlattenSettings(
        spacing=args.spacing, spacing_warp=args.spacing_warp, material=_material(args),
        seed=seed, angle_deg=0.0 if args.angle == "auto" else args.angle, paths=args.paths, solver=args.solver,
        tol=args.tol, max_iter=args.max_iter,
        max_seconds=args.max_seconds if args.max_seconds is not None else float("inf"),
        yarns=_yarns(args), darts=_darts(args, surface), max_nodes=args.max_nodes, region=region)
    initial = None
    if args.warm_start:
        if args.angle == "auto":
            raise SettingsError("--angle auto drapes anew at each angle; it cannot warm-start (drop --warm-start)")
        initial = state_from_dict(_read_json(args.warm_start), surface, settings)
    swept = None
    if args.angle == "auto":
        swept = sweep(surface, settings, refine=True, area=cover.area if cover.trimmed else None,
                      seeds=1)
        settings = dataclasses.replace(settings, angle_deg=swept.best["angle_deg"])
        if not args.quiet:
            print(f"angle auto: {swept.best['angle_deg']:.4g} deg, the best of {len(swept.rows)} solves "
                  f"({swept.seconds:.1f} s)" + _no_usable_angle(swept.best), file=sys.stderr)
    result = flatten(surface, settings, initial=initial, area=cover.area if cover.trimmed else region_area(surface),
                     callback=None if args.quiet else _Progress())
    suggested = []
    if args.auto_darts:

        suggested = suggest_darts(result, count=args.auto_darts)
        if suggested:
            result = suggested[-1].result
        if not args.quiet:
            for p in suggested:
                print(f"{p.dart.name}: energy {-100 * p.gain:+.1f} %, boundary error "
                      f"{p.metrics['boundary_error_pct']:.3f} %, area error {p.metrics['area_error_pct']:.3f} % "
                      f"({p.result.status})", file=sys.stderr)
            if len(suggested) < args.auto_darts:
                print(f"{len(suggested)} of {args.auto_darts} suggested darts: {suggested.reason}", file=sys.stderr)
    if out is not None:
        doc = result_to_dict(result, source)
        doc["warnings"] = notes + doc["warnings"]
        if swept is not None:
            doc["sweep"] = swept.to_dict()
        if args.auto_darts:
            doc["suggested_darts"] = [p.to_dict() for p in suggested]
        if opened.cad is not None:  # which face of which file, in which units
            doc["settings"]["face"] = opened.face
            if opened.face is None:  # several faces joined (--faces)
                doc["settings"]["faces"] = list(surface.fit.faces)
            doc["settings"]["units"] = opened.cad.units
        elif opened.units_guess is not None or args.units is not None:  # a mesh: the units taken, kept
            doc["settings"]["units"] = units
        files = [(out, json_bytes(doc, out))]
    else:
        files = []
    # a surprising export (hundreds of pages, a piece metres across) is written, but said first
    assumed = args.units is None and opened.cad is None  # a mesh or surface file's units are taken as m
    hint = f"; --units gives the model's units if they are not {units}" if assumed else ""
    _print_warnings(s.line() + hint for s in surprises(result, targets, options))
    # the result and the exports all or nothing: an export that fails leaves --out as it was
    atomic_write_many(files + (export_files(result, targets, options) if targets else []))
    written = targets
    m = result.metrics
    if not args.quiet:
        print(f"{m['nodes']} nodes, {m['springs']} springs, energy {m['energy']:.6g}, "
              f"boundary error {m['boundary_error_pct']:.3f} %, area error {m['area_error_pct']:.3f} %, "
              f"max thread strain {m['max_thread_strain_pct']:.3g} %, max shear {m['max_shear_deg']:.3g} deg, "
              f"{m['area_beyond_lock_pct']:.3g} % of the area beyond the lock angle "
              f"({result.settings.material.lock_deg:g} deg), "
              f"{m['iterations']} iterations ({result.status})"
              + _coarse_note(m)
              + f", {m['seconds']:.2f} s"
              + "".join(f" -> {p}" for p in ([out] if out else []) + written), file=sys.stderr)
    _print_warnings(result.warnings)
    return 0


def _flatten_panels(args, opened, out: Path | None, targets, notes: list, options) -> int:
    """``flatten --seam ...`` on a surface: the region split into panels by the seams
    (:func:`flatweave.document.sewing.sew`), each flattened with the settings given (its own
    seed, at its middle), their sew lines matched (:func:`flatweave.document.checks.seam_rows`);
    ``--out`` the panels' result file, or the project (its seams kept) when named ``.flatweave``."""
    used = [name for name, given in (("--seed", args.seed is not None), ("--angle auto", args.angle == "auto"),
                                      ("--warm-start", bool(args.warm_start)), ("--auto-darts", bool(args.auto_darts)),
                                      ("--plane-dart", bool(args.plane_dart)), ("--curve-dart", bool(args.curve_dart)),
                                      ("--yarn", bool(args.yarn))) if given]
    if used:
        raise SettingsError(f"{', '.join(used)} {'is' if len(used) == 1 else 'are'} not taken with --seam on a "
                            f"surface yet: each panel is flattened at its middle with the settings given")
    flat_only = [p.name for p in targets if not exporter_for(p.suffix).needs_sheet]
    if flat_only:
        raise SettingsError(f"{', '.join(flat_only)}: panels are exported as flat patterns (DXF, SVG, PDF), not "
                            f"yet in 3D formats")
    surface, source = opened.surface, opened.source
    seams = [seam_line_from_spec(surface, _read_json(path, "seam"), f"seam {k + 1}")
             for k, path in enumerate(args.seam)]
    region = opened.region
    settings = FlattenSettings(
        spacing=args.spacing, spacing_warp=args.spacing_warp, material=_material(args), angle_deg=args.angle,
        paths=args.paths, solver=args.solver, tol=args.tol, max_iter=args.max_iter,
        max_seconds=args.max_seconds if args.max_seconds is not None else float("inf"), max_nodes=args.max_nodes,
        region=region, seed=cover_for(surface, region).default_seed)
    # the shape a piece of a project, split into panels (its pieces), solved at once in worker processes
    project = sew(Project(surface, settings, name=Path(args.surface).stem, source=source, units=options.units),
                  0, seams)
    project, outcomes, matching = solve_all(project)
    failed = [o for o in outcomes if o.result is None]
    if failed:
        raise SettingsError(f"{failed[0].name}: {failed[0].error}")
    pieces = project.pieces
    rows = seam_rows(project)
    warnings = list(notes) + [f"{p.name}: {w}" for p in pieces for w in p.result.warnings] + seam_warnings(project)
    doc = {"format": "flatweave-panels", "version": 1, "flatweave": __version__, "surface": source,
           "units": options.units,
           "seams": [r.to_dict() for r in rows if len(r.panels) == 2],
           "panels": [{"name": p.name, "sews": sorted(r.name for r in rows if p.name in r.panels),
                       "result": result_to_dict(p.result, source)} for p in pieces],
           "pattern": {"pieces": [{"panel": p.name, **pc.to_dict()} for p in pieces for pc in p.result.pattern.pieces]},
           **({"matching": matching.to_dict()} if matching.lines else {}),
           "warnings": warnings + ([] if matching.reached else [matching.message])}
    exports = []
    if targets:  # the panels' flat patterns on one sheet (a DXF block each), notched and with their allowances
        joined = join_sheets([piece_sheet(project, p.name, options.seam_allowance_mm, args.notch_every,
                                          f"{options.name} {p.name}") for p in pieces], options.name)
        exports = [f for path in targets for f in exporter_for(path.suffix).files(pieces[0].result, options,
                                                                                   joined, path)]
    if out is not None and out.suffix.lower() == PROJECT_SUFFIX:  # the panels as a project's pieces, seams kept
        files = [(out, json_bytes(project_to_dict(project), out))]
    else:
        files = [(out, json_bytes(doc, out))] if out is not None else []
    atomic_write_many(files + exports)  # the result file and every export, all or nothing
    if not args.quiet:
        for p in pieces:
            m = p.result.metrics
            print(f"{p.name}: {m['nodes']} nodes, boundary error {m['boundary_error_pct']:.3f} %, area error "
                  f"{m['area_error_pct']:.3f} %, max shear {m['max_shear_deg']:.3g} deg ({p.result.status})",
                  file=sys.stderr)
        for r in rows:
            if r.solved:
                print(f"sew line {r.name} ({r.panels[0]} / {r.panels[1]}): {r.lengths[0]:.6g} / {r.lengths[1]:.6g}, "
                      f"{r.difference_pct:.3g} % apart", file=sys.stderr)
        written = ([out] if out is not None else []) + list(targets)
        if matching.message:
            print(f"matched seams: {matching.message}", file=sys.stderr)
        n = sum(r.solved for r in rows)
        print(f"{len(pieces)} panel{'s' if len(pieces) != 1 else ''}, {n} sew "
              f"line{'s' if n != 1 else ''}" + "".join(f" -> {p}" for p in written), file=sys.stderr)
    _print_warnings(warnings[len(notes):])
    return 0


def _coarse_note(m: dict) -> str:
    """The summary line's words on the iterations spent before the fine solve."""
    if m.get("coarse_levels"):
        return (f", {m['coarse_iterations']} of them on {m['coarse_levels']} coarser level"
                f"{'s' if m['coarse_levels'] > 1 else ''}")
    if m.get("coarse_iterations"):  # a coarse solve showed the drape holds (flatweave.method.pipeline._start)
        return f", {m['coarse_iterations']} of them on a coarser drape that held"
    return ""


def _check_face_size(opened, spacing: float) -> None:
    """SettingsError when the chosen face (or every face of the file) is too
    small for the spacing: less area than 4 cells."""
    faces = opened.cad.faces
    need = 4.0 * spacing * spacing
    name = Path(opened.cad.path).name
    largest = max(float(f.area) for f in faces)
    if largest < need:
        raise SettingsError(f"every face of {name} is too small for spacing {spacing:g} (the largest has area "
                            f"{largest:.4g} {opened.cad.units}^2); use a spacing below about "
                            f"{0.5 * largest ** 0.5:.2g}")
    face = opened.cad.face(opened.face)
    if float(face.area) < need:
        raise SettingsError(f"face {face.index} of {name} (area {face.area:.4g} {opened.cad.units}^2) is too small "
                            f"for spacing {spacing:g}; use a spacing below about {0.5 * face.area ** 0.5:.2g} "
                            f"or another face")


def _material(args):
    """The --material, with the --shear-angles given."""
    from dataclasses import replace

    material = parse_material(args.material)
    if getattr(args, "shear_angles", None) is None:
        return material
    try:
        warn, lock = (float(x) for x in args.shear_angles.split(","))
    except ValueError:
        raise SettingsError(f"--shear-angles must be two numbers WARN,LOCK in degrees, "
                            f"got {args.shear_angles!r}") from None
    return replace(material, warn_deg=warn, lock_deg=lock)


def _print_warnings(warnings) -> None:
    """Each warning as ``flatweave: warning: ...`` on stderr, even with --quiet
    (warnings are about the result, not progress); the exit status stays 0."""
    for w in warnings:
        print(f"flatweave: warning: {w}", file=sys.stderr)


def _cmd_flatten_planar(args, out: Path) -> int:
    """``flatten --method planar``: the comparison method of flatweave.studies.planar."""

    unused = [name for name, value, default in (
        ("--spacing-warp", args.spacing_warp, None), ("--material", args.material, "woven"),
        ("--shear-angles", args.shear_angles, None),
        ("--seed", args.seed, None), ("--angle", args.angle, 0.0), ("--paths", args.paths, "plane"),
        ("--region", args.region, None), ("--seam", args.seam, []), ("--region-offset", args.region_offset, None),
        ("--face", args.face, None),
        ("--faces", args.faces, None),
        ("--yarn", args.yarn, []), ("--warm-start", args.warm_start, None),
        ("--auto-darts", args.auto_darts, 0)) if value != default]
    if unused:
        raise SettingsError(f"--method planar does not use {', '.join(unused)}")
    solvers = solver_entry("planar").solver_map  # --solver name -> the planar method's minimiser
    if args.solver not in solvers:
        raise SettingsError("--method planar has solvers fast (Levenberg-Marquardt) and none (the unfolding only)")
    surface, source = resolve_surface(args.surface)
    if reader_region(args.surface):
        raise SettingsError("--method planar covers a whole surface, not a trimmed face; use --method spring")
    settings = PlanarSettings(
        spacing=args.spacing, darts=_darts(args, surface), solver=solvers[args.solver],
        tol=args.tol, max_iter=args.max_iter,
        max_seconds=args.max_seconds if args.max_seconds is not None else float("inf"), max_nodes=args.max_nodes)
    result = flatten_planar(surface, settings)
    write_json(out, planar_result_to_dict(result, source))
    m = result.metrics
    if not args.quiet:
        print(f"planar: {m['nodes']} nodes, {m['triangles']} triangles, energy {m['energy']:.6g}, "
              f"boundary error {m['boundary_error_pct']:.3f} %, area error {m['area_error_pct']:.3f} %, "
              f"max edge strain {m['max_edge_strain_pct']:.3g} %, {m['flipped_triangles']} flipped, "
              f"{m['iterations']} iterations ({result.status}), {m['seconds']:.2f} s -> {out}",
              file=sys.stderr)
    _print_warnings(result.warnings)
    return 0


class _Progress:
    """Progress of long runs on stderr: a line at most every half second."""

    def __init__(self, every: float = 0.5):
        self.every = every
        self.next = time.perf_counter() + every

    def __call__(self, snap) -> bool:
        now = time.perf_counter()
        if now >= self.next:
            self.next = now + self.every
            print(f"  iteration {snap.iteration}: energy {snap.energy:.9g}, {snap.mesh.n_nodes} nodes, "
                  f"{snap.seconds:.1f} s", file=sys.stderr)
        return False


def _read_json(path: str, what: str = "result") -> dict:
    raw = read_input(path, "result" if what == "result" else "small", SettingsError)
    return parse_json(raw, path, f"JSON {what} file", SettingsError)


def _cmd_sweep(args) -> int:
    out = Path(args.out) if args.out else None
    if out is not None and out.parent and not out.parent.exists():
        raise SettingsError(f"cannot write {out}: folder {out.parent} does not exist")
    _check_outputs(args, [out] if out else [])
    opened = resolve_piece(args)
    _print_warnings(opened.notes)
    surface, region = opened.surface, opened.region
    cover = cover_for(surface, region)
    seed = _floats(args.seed, 2, "seed") if args.seed is not None else cover.default_seed
    settings = FlattenSettings(
        spacing=args.spacing, spacing_warp=args.spacing_warp, material=_material(args), seed=seed,
        paths=args.paths, solver=args.solver, tol=args.tol, max_iter=args.max_iter,
        darts=_darts(args, surface), region=region)
    if args.lock_angle is not None and not (0 < args.lock_angle < 90):
        raise SettingsError(f"--lock-angle must be between 0 and 90 degrees, got {args.lock_angle:g}")
    result = sweep(surface, settings, angles=args.angles, seeds=args.seeds, lock_deg=args.lock_angle,
                   refine=args.refine, workers=args.workers, area=cover.area if cover.trimmed else None)
    if out is not None:
        write_json(out, result.to_dict())
    if not args.quiet:
        print(f"{'rank':>4} {'angle':>7} {'seed':>13} {'beyond lock %':>13} {'max shear':>9} "
              f"{'boundary %':>10} {'area %':>7} {'nodes':>6}  pattern")
        for k, r in enumerate(result.rows, 1):
            seed_text = f"{r['seed'][0]:.3f},{r['seed'][1]:.3f}"
            if r.get("error"):
                print(f"{k:>4} {r['angle_deg']:>7.2f} {seed_text:>13}  failed: {r['error']}")
                continue
            print(f"{k:>4} {r['angle_deg']:>7.2f} {seed_text:>13} {r['area_beyond_lock_pct']:>13.3f} "
                  f"{r['max_shear_deg']:>9.3f} {r['boundary_error_pct']:>10.3f} {r['area_error_pct']:>7.3f} "
                  f"{r['nodes']:>6}  " + ("not usable: " + ", ".join(r["unusable"]) if r.get("unusable")
                                          else "usable"))
    print(f"best: weft angle {result.best['angle_deg']:.4g} deg, seed {result.best['seed'][0]:.4g},"
          f"{result.best['seed'][1]:.4g} ({len(result.rows)} solves, {result.seconds:.1f} s)"
          + _no_usable_angle(result.best) + (f" -> {out}" if out else ""), file=sys.stderr)
    return 0


def _no_usable_angle(best: dict) -> str:
    """The sweep's summary line's words when even its best row's pattern is not usable."""
    return f", no angle gives a usable pattern: {', '.join(best['unusable'])}" if best.get("unusable") else ""


def _cmd_info(args) -> int:
    import json

    faces = _face_list(args)
    opened = open_path(args.surface, surface_only=True)
    if faces is not None:  # several faces joined: the piece and its fit, as for a mesh
        opened = _join_faces(args, opened, faces)
        return _info_mesh(opened, opened.surface.fit, args.json)
    if opened.cad is not None:

        info = cad_info(opened.cad)
        if args.face is not None:
            opened.with_face(args.face)  # a face that is not there: one line
            info["faces"] = [f for f in info["faces"] if f["index"] == args.face]
        if args.json:
            print(json.dumps(info))
            return 0
        print(f"{opened.source}: {len(info['faces'])} face{'s' if len(info['faces']) != 1 else ''}, "
              f"units {info['units']}")
        for f in info["faces"]:
            box = ", ".join(f"{x:.6g}" for x in f["bbox"])
            print(f"  face {f['index']}: {f['kind']}, area {f['area']:.10g}, "
                  f"{'trimmed' if f['trimmed'] else 'untrimmed'}, bbox [{box}]")
        return 0
    tolerance = _fit_tolerance(args)
    if tolerance is not None and opened.mesh is None:
        raise SettingsError(f"{Path(args.surface).name}: --fit-tolerance is for meshes (a surface file is "
                            f"the surface itself)")
    if opened.mesh is not None and opened.surface is None:
        if opened.mesh.needs_region:  # closed, or with handles: described; only flattening it needs a region
            return _info_mesh(opened, None, args.json)
        opened = opened.choose_face(args.face)  # a mesh of several parts: part --face N, or how to choose one
    if opened.mesh is not None and tolerance is not None:
        opened = opened.refitted(tolerance)
    surface, source = opened.surface, opened.source
    fit = getattr(surface, "fit", None)
    if fit is not None:  # a mesh: the piece is the map's region, and the fit's deviation is the news
        return _info_mesh(opened, fit, args.json)
    if args.json:
        d = surface.domain
        print(json.dumps({"domain": d.tolist(), "area": region_area(surface),
                          "boundary_length": boundary_length(surface)}))
        return 0
    d = surface.domain
    print(f"{source}: {surface!r}")
    print(f"domain u [{d[0, 0]:g}, {d[0, 1]:g}], v [{d[1, 0]:g}, {d[1, 1]:g}]")
    print(f"area {region_area(surface):.10g}, boundary length {boundary_length(surface):.10g}")
    return 0


def _info_mesh(opened, fit, as_json: bool) -> int:
    """``info`` of a mesh made a surface (flatweave.geometry.meshfit): the fit and the piece. With ``fit``
    None, a mesh that cannot be covered whole (``opened.mesh``, closed or with handles): its
    vertices and triangles after repair, boundary loops and genus, size (bounding-box diagonal)
    and area, and that a region is needed to flatten it."""
    import json

    if fit is None:
        import numpy as np

        mesh = opened.mesh
        if mesh.cleaned is not None:  # the open repaired it already
            V, F, repairs = mesh.cleaned
        else:
            try:  # described, not refused: its non-manifold edges set aside, its largest part when they split it
                V, F, repairs = clean_mesh(mesh.vertices, mesh.triangles, mesh.path.name, aside=[])
            except SeveralParts:
                V, F, repairs = clean_mesh(mesh.vertices, mesh.triangles, mesh.path.name, 0, aside=[])
        n_loops = len(boundary_loops(F, mesh.path.name))
        n_edges = len(edge_table(F)[0])
        genus = (2 - (len(V) - n_edges + len(F)) - n_loops) // 2  # Euler: V - E + F = 2 - 2g - loops
        size = float(np.linalg.norm(np.ptp(V, axis=0)))
        area = float(0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1).sum())
        if as_json:
            print(json.dumps({"vertices": len(V), "triangles": len(F), "closed": n_loops == 0,
                              "boundary_loops": n_loops, "genus": genus, "size": size, "area": area,
                              "repairs": list(repairs), "needs_region": mesh.needs_region,
                              "units_guess": opened.units_guess}))
            return 0
        shape = "closed (no boundary)" if n_loops == 0 else f"{n_loops} boundary loop{'s' if n_loops != 1 else ''}"
        handles = f"{genus} handle{'s' if genus != 1 else ''}"
        print(f"{opened.source}: mesh of {len(V)} vertices and {len(F)} triangles"
              + (f" ({'; '.join(repairs)})" if repairs else ""))
        print(f"{shape}, genus {genus} ({handles}); size {size:.6g} (bounding-box diagonal), area {area:.10g}")
        if opened.units_guess is not None:
            print(f"{units_note(mesh.path.name, size, opened.units_guess)}; flatten --units chooses")
        if len(F) > meshfit.MAX_FIT_TRIANGLES:  # too detailed to fit whole (meshfit.TooDetailed): a panel, or decimate
            print(mesh.needs_region)
        else:
            print("it needs a region to flatten: give flatten --region with a loop3d drawn on it, "
                  "or cut the piece out of the mesh (the window's Open does)")
        return 0
    cover = cover_for(opened.surface, opened.region)
    if as_json:
        print(json.dumps({"domain": opened.surface.domain.tolist(), "area": cover.area,
                          "boundary_length": cover.boundary_length, "holes": opened.region.n_holes,
                          "fit": fit.to_dict(), **fit.metrics(), "units_guess": opened.units_guess}))
        return 0
    what = f"faces {', '.join(map(str, fit.faces))} joined: " if fit.faces else ""
    print(f"{opened.source}: {what}mesh of {fit.vertices} vertices and {fit.triangles} triangles"
          + (f" ({'; '.join(fit.repairs)})" if fit.repairs else ""))
    print(f"surface: {opened.surface!r}, {fit.describe()}")
    print(f"area {cover.area:.10g}, boundary length {cover.boundary_length:.10g}, "
          f"{opened.region.n_holes} hole{'s' if opened.region.n_holes != 1 else ''}")
    if opened.units_guess is not None:
        print(f"{units_note(Path(opened.source).name, fit.size, opened.units_guess)}; flatten --units chooses")
    return 0


def _cmd_solve(args) -> int:
    """``solve PROJECT.flatweave``: every piece (or the --piece ones) solved in worker processes
    (flatweave.document.solving), the project saved with their results, a table of them on stdout.
    Exit 0 when every piece was solved, 1 when one failed (its line on stderr; the others are saved)."""
    src = Path(args.project)
    bundled = not exists(src) and src.parent == Path(".") and src.stem in job_names()
    if bundled:  # a bundled example job by name: its project is written here, not beside the package's file
        src = job_path(src.name)
    job = src.suffix.lower() == JOB_SUFFIX
    if src.suffix.lower() != PROJECT_SUFFIX and not job:
        raise SettingsError(f"{src.name}: solve takes a project ({PROJECT_SUFFIX}, saved by the window) or a job "
                            f"file ({JOB_SUFFIX})")
    if args.dask is not None and args.workers is not None:
        raise SettingsError("--dask and --workers contradict: the Dask cluster's workers solve the pieces")
    out = Path(args.out) if args.out else Path(src.with_suffix(PROJECT_SUFFIX).name) if bundled \
        else src.with_suffix(PROJECT_SUFFIX) if job else src
    if out.suffix.lower() != PROJECT_SUFFIX:
        raise SettingsError(f"--out {out.name}: the solved project is written as a {PROJECT_SUFFIX} file")
    if out.parent and not out.parent.exists():
        raise SettingsError(f"cannot write {out}: folder {out.parent} does not exist")
    book = Path(args.ply_book) if args.ply_book else None
    if book is not None:
        if book.suffix.lower() != ".pdf":
            raise SettingsError(f"--ply-book {book.name}: a ply book is a PDF (.pdf)")
        check_target(book)
    check_output(out, SettingsError)  # a project over a device, or a pipe, is never written
    folder = check_folder(args.export) if args.export else None
    options = ExportOptions(seam_allowance_mm=args.seam_allowance, paper=args.paper)
    project = open_path(src).project  # the registry's project readers: .flatweave and .toml
    names = args.piece or None
    if names is not None:
        for name in names:  # a name that is not there: one line before anything is solved
            index_of(project, name)

    def progress(outcome):
        if not args.quiet:
            what = f"failed: {outcome.error}" if outcome.error else outcome.result.status
            print(f"  {outcome.name}: {what} ({outcome.seconds:.1f} s)", file=sys.stderr)

    project, outcomes, matching = solve_all(project, names, args.workers, on_done=progress, cluster=args.dask)
    if matching.message and not args.quiet:
        print(f"  matched seams: {matching.message}", file=sys.stderr)
    _save_solved(project, out, book, folder, options, args.quiet, args.notch_every)
    if not args.quiet:
        print(f"{'piece':<24} {'orient.':>8} {'status':<28} {'nodes':>7} {'boundary %':>10} {'area %':>8} "
              f"{'shear deg':>9} {'seconds':>8}")
        by_name = {p.name: p for p in project.pieces}
        for o in outcomes:
            orient = orientation_text(by_name[o.name], short=True)
            if o.result is None:
                print(f"{o.name[:24]:<24} {orient:>8} {'failed':<28}")
                continue
            m = o.result.metrics
            print(f"{o.name[:24]:<24} {orient:>8} {o.result.status[:28]:<28} {m['nodes']:>7} "
                  f"{m['boundary_error_pct']:>10.3f} {m['area_error_pct']:>8.3f} "
                  f"{m.get('max_shear_deg', float('nan')):>9.2f} {o.seconds:>8.2f}")
        rows = seam_rows(project)
        if rows:  # the panels' sew lines matched (issue 42)
            print(f"{'sew line':<24} {'panels':<33} {'lengths':>21} {'diff. %':>8}")
            for r in rows:
                lengths = " / ".join("-" if v is None else f"{v:.6g}" for v in r.lengths)
                diff = "-" if r.difference_pct is None else f"{r.difference_pct:.3g}"
                sides = " / ".join(n or "(deleted)" for n in r.panels)
                print(f"{r.name[:24]:<24} {sides[:33]:<33} {lengths:>21} {diff:>8}")
        print(f"-> {out}")
    _print_warnings(project_checks(project))  # the pieces judged together: sequence, materials, fibres
    failed = [o for o in outcomes if o.result is None]
    for o in failed:
        print(f"flatweave: piece {o.name!r} failed: {o.error}", file=sys.stderr)
    return PIECES_FAILED if failed else 0


def _save_solved(project, out: Path, book: Path | None, folder: Path | None, options: ExportOptions,
                 quiet: bool, notch_every_mm: float = 0.0) -> None:
    """The solved project saved with its ply book and cut files, all or nothing: every file is built,
    then staged, and the project saved, before any replaces its target."""
    extra = [(book, plybook_bytes(project, options.paper, options.seam_allowance_mm))] if book else []

    def save():
        save_with_backups(project, out)
    if folder is None:
        atomic_write_many(extra, before_replace=save)
        return
    if not any(p.result is not None for p in project.pieces):  # nothing to cut; the failures are said below
        atomic_write_many(extra, before_replace=save)
        print("flatweave: warning: no piece is solved: no cut files written", file=sys.stderr)
        return
    paths, left = export_pieces(project, folder, options=options, extra=extra, before_replace=save,
                                notch_every_mm=notch_every_mm)
    if not quiet:
        print(f"{len(paths) - len(extra)} cut files -> {folder}", file=sys.stderr)
    if left:
        names = ", ".join(repr(n) for n in left[:5]) + (f" and {len(left) - 5} more" if len(left) > 5 else "")
        print(f"flatweave: warning: no cut files for {len(left)} piece{'s' if len(left) > 1 else ''} with no current "
              f"result: {names}", file=sys.stderr)


def _nest_input(text: str) -> tuple[Path, int]:
    """An INPUT[:QTY] of nest: the file and its copies."""
    path, sep, qty = text.rpartition(":")
    if sep and qty.isdigit() and path:
        copies = int(qty)
        if not 1 <= copies <= 100_000:
            raise SettingsError(f"{text}: the copies after ':' must be a whole number from 1 to 100000")
        return Path(path), copies
    return Path(text), 1


def _nest_items(path: Path, copies: int, args) -> tuple:
    """The plan items of one nest input, the roll width it knows (mm, or None), the pieces left out and,
    for a project, its cut plan (:class:`flatweave.document.cutsettings.CutPlanSettings`; else None)."""
    name = cutplan.source_name(path)
    allowance = 0.0 if args.seam_allowance is None else args.seam_allowance
    if path.suffix.lower() == PROJECT_SUFFIX:
        project = load_project(path)
        plan = project.cut_plan
        allowance = plan.allowance_mm if args.seam_allowance is None else args.seam_allowance
        items, left = cutplan.project_items(project, name, allowance, copies, args.rotations or plan.rotations)
        known = [plan.width_for(it.material) or getattr(project.fabric(it.material), "roll_width_mm", None)
                 for it in items]
        return items, (known[0] if known and len(set(known)) == 1 else None), left, plan
    doc = _read_json(str(path))
    if isinstance(doc, dict) and "strip_height" in doc and "items" in doc:  # a nesting instance
        return cutplan.instance_items(doc, name, copies, args.rotations), float(doc["strip_height"]), [], None
    if not isinstance(doc, dict) or doc.get("format") != "flatweave-result":
        raise SettingsError(f"{path.name}: nest takes a project (.flatweave), a result file (flatten --out) or a "
                            f"nesting instance (sparrow's JSON: items, strip_height)")
    surface = doc.get("surface")
    if not isinstance(surface, str):
        raise SettingsError(f"{path.name}: the result does not say its surface; nest its project instead")
    where = Path(surface) if exists(Path(surface)) or not exists(path.parent / surface) else path.parent / surface
    try:
        opened = open_path(where, surface_only=True)
    except FlatweaveError as exc:
        raise SettingsError(f"{path.name}: its surface {surface!r} cannot be opened here ({exc}); nest its "
                            f"project instead (flatten --out NAME.flatweave)") from None
    result = result_from_dict(doc, opened.surface, str(path))
    units = doc.get("settings", {}).get("units") or opened.units or "m"
    items = cutplan.result_items(result, path.stem, name, units, allowance, copies, args.rotations)
    return items, None, [], None


def _mirrored(items, names: list[str]) -> list:
    """``items`` with those named by ``--mirror NAME`` (a piece's name: its item, or its items "NAME K" when
    its pattern has several pieces) cut in mirror pairs; a one-line SettingsError for a name none has."""
    out = list(items)
    for name in names:
        hit = [k for k, it in enumerate(out) if part_of(it.item.name, name) is not None]
        if not hit:
            raise SettingsError(f"--mirror {name!r:.60}: no piece to nest is named so (the pieces: "
                                f"{', '.join(it.item.name for it in out)[:200]})")
        for k in hit:
            out[k] = dataclasses.replace(out[k], item=dataclasses.replace(out[k].item, mirror=True))
    return out


def _splices(given: list[str]) -> dict:
    """``--splice NAME=MM[,MM...]`` options as {name: [mm, ...]}."""
    out = {}
    for text in given:
        name, sep, values = text.rpartition("=")
        try:
            at = [float(v) for v in values.split(",")] if sep and name else []
        except ValueError:
            at = []
        if not at or not all(math.isfinite(v) for v in at):
            raise SettingsError(f"--splice {text!r:.60}: give NAME=MM[,MM...], a piece's name and positions in mm")
        out[name] = at
    return out


def _cmd_nest(args) -> int:
    """``nest INPUT[:QTY]...``: every piece on the roll (a marker per material), sparrow placing them; the
    marker's length and utilisation on stderr, the markers exported."""
    targets = []
    for t in args.export:
        path = Path(t)
        if path.suffix.lower() not in MARKER_FORMATS:
            raise SettingsError(f"--export {path.name}: a marker is written as {', '.join(MARKER_FORMATS)}")
        if path.parent and not path.parent.exists():
            raise SettingsError(f"cannot write {path}: folder {path.parent} does not exist")
        check_output(path, SettingsError)
        targets.append(path)
    book = Path(args.ply_book) if args.ply_book else None
    projects = [p for p, _ in map(_nest_input, args.inputs) if p.suffix.lower() == PROJECT_SUFFIX]
    if book is not None:
        if book.suffix.lower() != ".pdf":
            raise SettingsError(f"--ply-book {book.name}: a ply book is a PDF (.pdf)")
        if len(projects) != 1 or len(args.inputs) != 1:
            raise SettingsError("--ply-book is the ply book of one project: give one project (.flatweave) as INPUT")
        check_target(book)
        check_output(book, SettingsError)
    items, widths, left, plans = [], [], [], []
    for text in args.inputs:
        path, copies = _nest_input(text)
        got, width, out, plan = _nest_items(path, copies, args)
        items += got
        widths.append(width)
        left += out
        plans.append(plan)
    # one project: its cut plan's settings where no option is given (several: the defaults)
    own = plans[0] if len(plans) == 1 and plans[0] is not None else CutPlanSettings()
    gap = own.gap_mm if args.gap is None else args.gap
    seconds = own.seconds if args.time_limit is None else args.time_limit
    overlap = own.overlap_mm if args.overlap is None else args.overlap
    allowance = own.allowance_mm if args.seam_allowance is None else args.seam_allowance
    items = _mirrored(items, args.mirror)
    if left:
        _print_warnings([f"{', '.join(left)}: not solved (or changed since): not nested"])
    if not items:
        raise SettingsError("no piece is solved: nothing to nest")
    width = args.roll_width
    if width is None:
        known = {w for w in widths if w is not None}
        if len(known) != 1:
            raise SettingsError("give the roll's width: --roll-width W (mm)" if not known else
                                "the inputs' rolls differ in width: give --roll-width W (mm)")
        width = known.pop()
    # a piece wider than the roll in every rotation it may take: spliced into the fewest parts that fit
    names = {it.item.name for it in items}
    placed = {n: at for plan in plans if plan is not None for n, at in plan.splice_map().items() if n in names}
    items, spliced = cutplan.splice_items(items, width, overlap, {**placed, **_splices(args.splice)})
    for r in spliced:
        at = ", ".join(f"{y - r.start:.0f}" for y in r.positions)
        why = "spliced as asked" if r.asked else "wider than the roll: spliced"
        print(f"{r.name}: {r.width:.1f} mm across, {why} into {len(r.parts)} parts at {at} mm from its edge "
              f"({overlap:g} mm overlap)", file=sys.stderr)
    groups = cutplan.by_material(items)
    files, markers = [], []
    for material, group in groups.items():
        def progress(marker, material=material):
            if not args.quiet:
                print(f"  {material}: {marker.length:.1f} mm, {100 * marker.utilisation:.2f} % "
                      f"({marker.seconds:.1f} s)", file=sys.stderr)
        marker = nest([g.item for g in group], width, gap, seconds, seed=args.seed,
                      on_progress=progress)
        sources = [g.source for g in group]
        mine = []
        for path in targets:
            target = path if len(groups) == 1 else path.with_name(
                f"{path.stem}-{file_stem(material)}{path.suffix}")
            mine += marker_files(marker, sources, target, f"{path.stem} {material}", paper=args.paper)
        markers.append((material, marker, [p for p, _ in mine], sources))
        files += mine
    if book is not None:  # the project's ply book, its markers' pages after its pieces'
        project = load_project(projects[0])
        files.append((book, plybook_bytes(project, args.paper, seam_allowance_mm=allowance,
                                          markers=[(m, k, src) for m, k, _, src in markers])))
    atomic_write_many(files)  # every marker's files and the book, all or nothing
    for material, m, written, _ in markers:
        print(f"{material}: marker {m.length:.1f} mm long on a roll {width:g} mm wide, utilisation "
              f"{100 * m.utilisation:.2f} %, waste {m.waste / 1e6:.4g} m^2, {len(m.placements)} pieces placed "
              f"in {m.seconds:.1f} s" + (" (stopped: the best so far)" if m.stopped else "")
              + "".join(f" -> {p}" for p in written), file=sys.stderr)
    return 0


def _cmd_examples(args) -> int:
    for e in list_examples():
        print(f"{e['name']:<14} {e.get('title', '')}  ({example_path(e['name'])})")
    for name in job_names():
        print(f"{name:<14} job: flatweave-cli solve {name}  ({job_path(name)})")
    return 0


PIECES_FAILED = 3
"""``solve``'s exit status when some pieces failed (each says why in a line; the others' results are
saved): neither bad input (2: nothing written) nor an internal error (1)."""


def main(argv=None) -> int:
    """Run the CLI; returns the exit status (0 ok, 2 bad input, 1 internal error, 3 ``solve``: some
    pieces failed, the others saved)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    handler = {"flatten": _cmd_flatten, "sweep": _cmd_sweep, "info": _cmd_info, "examples": _cmd_examples,
               "solve": _cmd_solve, "nest": _cmd_nest}[args.command]
    try:
        # numbers that overflow become infinities the checks refuse in one line: numpy's warnings about
        # them would only be printed above it
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            return handler(args)
    except FlatweaveError as exc:
        print(f"flatweave: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("flatweave: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # a bug: say so in one line, traceback only on request
        if args.debug or os.environ.get("FLATWEAVE_DEBUG"):
            traceback.print_exc()
        print(f"flatweave: internal error: {type(exc).__name__}: {exc} (run with --debug for details)",
              file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
