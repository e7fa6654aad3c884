"""Several faces of a CAD file joined into one surface (``--faces``, flatweave.reading.cadjoin.join_faces).

The files are made here with Open CASCADE, and Open CASCADE in this process
is the oracle: ``BRepGProp`` areas of the faces and lengths of the piece's
free edges. A plate, a quarter-cylinder fillet and a plate make a developable
piece, so its pattern must be its exact development (area and boundary); the
lid of a box with rounded edges and corners (a plane, cylinders and spheres)
is doubly curved: its fitted surface must keep the faces' area and outline.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from flatweave.errors import SettingsError
from tests.helpers import needs_ocp

pytestmark = needs_ocp  # Open CASCADE makes and reads the STEP files (a dev dependency)

ROOT = Path(__file__).resolve().parent.parent
L1, R, L2, W = 40.0, 8.0, 30.0, 25.0  # plate, fillet radius, plate, width (mm)
BOX, ROUND = (40.0, 30.0, 20.0), 5.0  # the box and the radius of its rounded edges


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "flatweave", *map(str, args)], capture_output=True, text=True,
                          cwd=ROOT, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"}, timeout=600)


def _static(cls, name):
    return getattr(cls, name + "_s", None) or getattr(cls, name)


def fillet_shell():
    """Plate (z = 0, x in [0, L1]), quarter cylinder of radius R, plate (x = L1 + R,
    z in [R, R + L2]), all W wide along y: a line-arc-line profile swept along y."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge, BRepBuilderAPI_MakeWire
    from OCP.BRepPrimAPI import BRepPrimAPI_MakePrism
    from OCP.GC import GC_MakeArcOfCircle
    from OCP.gp import gp_Pnt, gp_Vec

    p0, p1, p2, p3 = gp_Pnt(0, 0, 0), gp_Pnt(L1, 0, 0), gp_Pnt(L1 + R, 0, R), gp_Pnt(L1 + R, 0, R + L2)
    mid = gp_Pnt(L1 + R * math.sin(math.pi / 4), 0, R - R * math.cos(math.pi / 4))
    arc = GC_MakeArcOfCircle(p1, mid, p2).Value()
    wire = BRepBuilderAPI_MakeWire(BRepBuilderAPI_MakeEdge(p0, p1).Edge(), BRepBuilderAPI_MakeEdge(arc).Edge(),
                                   BRepBuilderAPI_MakeEdge(p2, p3).Edge()).Wire()
    return BRepPrimAPI_MakePrism(wire, gp_Vec(0, W, 0)).Shape()


def rounded_box():
    """A box with every edge rounded (radius ROUND): planes, cylinders, sphere corners."""
    from OCP.BRepFilletAPI import BRepFilletAPI_MakeFillet
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp_Explorer

    box = BRepPrimAPI_MakeBox(*BOX).Shape()
    mk = BRepFilletAPI_MakeFillet(box)
    ex = TopExp_Explorer(box, TopAbs_EDGE)
    while ex.More():
        mk.Add(ROUND, _static(__import__("OCP.TopoDS", fromlist=["TopoDS"]).TopoDS, "Edge")(ex.Current()))
        ex.Next()
    return mk.Shape()


def occ_faces(shape):
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS
    out, ex = [], TopExp_Explorer(shape, TopAbs_FACE)
    while ex.More():
        out.append(_static(TopoDS, "Face")(ex.Current()))
        ex.Next()
    return out


def free_edge_length(shape, indices) -> float:
    """BRepGProp's length of the edges that belong to one of the faces only: the piece's outline."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS
    faces = occ_faces(shape)
    edges = []
    for i in indices:
        ex = TopExp_Explorer(faces[i], TopAbs_EDGE)
        while ex.More():
            edges.append(_static(TopoDS, "Edge")(ex.Current()))
            ex.Next()
    total = 0.0
    for e in edges:
        if sum(1 for o in edges if o.IsSame(e)) == 1:
            props = GProp_GProps()
            _static(BRepGProp, "LinearProperties")(e, props)
            total += props.Mass()
    return total


@pytest.fixture(scope="module")
def fillet_file(tmp_path_factory):
    from tests import cadfiles as cf
    return cf.write_step(fillet_shell(), tmp_path_factory.mktemp("join") / "fillet.step")


@pytest.fixture(scope="module")
def fillet_piece(fillet_file):
    from flatweave.reading.cadjoin import join_faces
    from flatweave.reading.cad import read_cad_faces
    cad = read_cad_faces(fillet_file)
    return cad, join_faces(cad, (0, 1, 2))


@pytest.fixture(scope="module")
def box_file(tmp_path_factory):
    from tests import cadfiles as cf
    return cf.write_step(rounded_box(), tmp_path_factory.mktemp("join") / "rounded.step")


@pytest.fixture(scope="module")
def box_cad(box_file):
    from flatweave.reading.cad import read_cad_faces
    return read_cad_faces(box_file)


def lid_faces(cad):
    """The top face of the rounded box and the rounds around it (4 cylinders, 4 sphere corners)."""
    top = BOX[2]
    return tuple(f.index for f in cad.faces if f.bbox[5] > top - 1e-6 and f.bbox[2] > top - ROUND - 1e-6)


# ---------------------------------------------------------------------- a developable piece across a fillet
@pytest.mark.slow
def test_the_oracle_is_what_the_shape_says(fillet_piece):
    cad, _ = fillet_piece
    assert [f.kind for f in cad.faces] == ["plane", "cylinder", "plane"]
    area = W * (L1 + L2 + math.pi * R / 2)
    assert sum(f.area for f in cad.faces) == pytest.approx(area, rel=1e-9)
    assert free_edge_length(fillet_shell(), (0, 1, 2)) == pytest.approx(2 * (L1 + L2 + math.pi * R / 2) + 2 * W,
                                                                         rel=1e-9)


@pytest.mark.slow
def test_joined_fillet_is_one_piece_with_a_close_fit(fillet_piece):
    from flatweave.geometry.meshfit import FittedSurface
    from flatweave.geometry.region import cover_for
    cad, piece = fillet_piece
    fit = piece.fit
    assert isinstance(piece.surface, FittedSurface) and fit.faces == (0, 1, 2)
    assert fit.source == cad.path
    assert piece.region.n_holes == 0
    assert fit.max_deviation < 1e-3 * fit.size and fit.mean_deviation < 2e-4 * fit.size
    # the fitted surface over the region keeps the faces' area and outline (Open CASCADE's)
    cover = cover_for(piece.surface, piece.region)
    assert cover.area == pytest.approx(sum(f.area for f in cad.faces), rel=1e-3)
    assert cover.boundary_length == pytest.approx(free_edge_length(fillet_shell(), (0, 1, 2)), rel=1e-3)
    # every vertex of the tessellation lies on one of the faces: the plates or the cylinder
    V = piece.vertices
    on_plate = (np.abs(V[:, 2]) < 1e-9) | (np.abs(V[:, 0] - (L1 + R)) < 1e-9)
    r = np.hypot(V[:, 0] - L1, V[:, 2] - R)
    assert np.all(on_plate | (np.abs(r - R) < 1e-3 * R))


def test_developable_join_flattens_to_its_development(fillet_piece):
    from shapely.geometry import Polygon

    from flatweave.method.settings import FlattenSettings
    from flatweave.method.pipeline import flatten
    from flatweave.geometry.region import cover_for
    cad, piece = fillet_piece
    cover = cover_for(piece.surface, piece.region)
    res = flatten(piece.surface, FlattenSettings(spacing=2.0, region=piece.region, seed=cover.default_seed),
                  area=cover.area)
    outline = Polygon(res.pattern.outline)
    assert outline.area == pytest.approx(sum(f.area for f in cad.faces), rel=1e-3)
    assert outline.length == pytest.approx(free_edge_length(fillet_shell(), (0, 1, 2)), rel=1e-3)
    # a development: L1 + pi R / 2 + L2 by W, a rectangle
    box = np.asarray(outline.minimum_rotated_rectangle.exterior.coords)[:4]
    sides = sorted(np.linalg.norm(box - np.roll(box, -1, axis=0), axis=1)[:2])
    assert sides == pytest.approx(sorted([W, L1 + L2 + math.pi * R / 2]), rel=2e-3)
    assert res.metrics["fit_max_deviation"] == piece.fit.max_deviation < 1e-3 * piece.fit.size


@pytest.mark.slow
def test_cli_flatten_with_faces(fillet_file, tmp_path):
    out = tmp_path / "r.json"
    r = _cli("flatten", fillet_file, "--faces", "0,1,2", "--spacing", "2.5", "--out", out, "--quiet")
    assert r.returncode == 0, r.stderr
    doc = json.loads(out.read_text())
    assert doc["settings"]["faces"] == [0, 1, 2] and doc["settings"]["face"] is None
    assert doc["settings"]["units"] == "mm"
    m = doc["metrics"]
    size = math.dist((0, 0, 0), (L1 + R, W, R + L2))
    assert 0 < m["fit_max_deviation"] < 1e-3 * size and 0 < m["fit_mean_deviation"] < 2e-4 * size
    assert m["area_error_pct"] < 0.1 and m["boundary_error_pct"] < 0.1
    r = _cli("info", fillet_file, "--faces", "1,0,2", "--json")
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout)
    assert info["fit"]["faces"] == [1, 0, 2] and info["holes"] == 0
    assert info["area"] == pytest.approx(W * (L1 + L2 + math.pi * R / 2), rel=1e-3)


# ---------------------------------------------------------------------- a doubly curved piece
@pytest.mark.slow
def test_lid_of_a_rounded_box_joins_planes_cylinders_and_spheres(box_cad):
    from flatweave.reading.cadjoin import join_faces
    from flatweave.method.settings import FlattenSettings
    from flatweave.method.pipeline import flatten
    from flatweave.geometry.region import cover_for
    lid = lid_faces(box_cad)
    kinds = sorted(box_cad.faces[i].kind for i in lid)
    assert len(lid) == 9 and kinds.count("plane") == 1, kinds
    piece = join_faces(box_cad, lid)
    fit = piece.fit
    assert fit.max_deviation < 1e-3 * fit.size and fit.mean_deviation < 2e-4 * fit.size
    cover = cover_for(piece.surface, piece.region)
    assert cover.area == pytest.approx(sum(box_cad.faces[i].area for i in lid), rel=1e-3)
    assert cover.boundary_length == pytest.approx(free_edge_length(rounded_box(), lid), rel=1e-3)
    res = flatten(piece.surface, FlattenSettings(spacing=2.5, region=piece.region, seed=cover.default_seed),
                  area=cover.area)
    assert res.metrics["solver_status"] == "converged"
    assert res.metrics["area_error_pct"] < 5 and res.metrics["fit_max_deviation"] == fit.max_deviation


# ---------------------------------------------------------------------- refusals
@pytest.mark.slow
def test_faces_that_do_not_make_one_piece_are_refused(box_cad):
    from flatweave.reading.cadjoin import join_faces
    top = next(f.index for f in box_cad.faces if f.kind == "plane" and f.bbox[2] > BOX[2] - 1e-6)
    bottom = next(f.index for f in box_cad.faces if f.kind == "plane" and f.bbox[5] < 1e-6)
    with pytest.raises(SettingsError, match="do not make one piece"):
        join_faces(box_cad, (top, bottom))
    with pytest.raises(SettingsError, match="out of range"):
        join_faces(box_cad, (top, 999))
    with pytest.raises(SettingsError, match="twice"):
        join_faces(box_cad, (top, top))


@pytest.mark.slow
def test_a_closed_choice_is_refused(box_cad):
    from flatweave.reading.cadjoin import join_faces
    with pytest.raises(SettingsError, match="closed surface"):
        join_faces(box_cad, tuple(range(len(box_cad.faces))))


def test_a_crash_while_tessellating_is_one_line(fillet_piece, monkeypatch):
    from flatweave.reading.cad import CadFileError
    from flatweave.reading.cadjoin import join_faces
    cad, _ = fillet_piece
    monkeypatch.setenv("FLATWEAVE_CAD_FAULT", "abort")  # the child dies by SIGABRT, as OCCT can
    with pytest.raises(CadFileError, match="crashed") as info:
        join_faces(cad, (0, 1))
    assert "\n" not in str(info.value)


@pytest.mark.slow
def test_an_iges_file_joins_too(tmp_path):
    from flatweave.reading.cadjoin import join_faces
    from flatweave.reading.cad import read_cad_faces
    from flatweave.geometry.region import cover_for
    from tests import cadfiles as cf
    cad = read_cad_faces(cf.write_iges(fillet_shell(), tmp_path / "fillet.igs"))
    piece = join_faces(cad, (0, 1, 2))
    assert cover_for(piece.surface, piece.region).area == pytest.approx(W * (L1 + L2 + math.pi * R / 2), rel=1e-3)
    assert piece.fit.max_deviation < 1e-3 * piece.fit.size


@pytest.mark.slow
@pytest.mark.parametrize("faces, words", [("0,2", "do not make one piece"), ("0,7", "out of range"),
                                          ("1,1", "given twice"), ("0,x", "separated by commas"),
                                          ("-1,0", "negative")])
def test_cli_refusals_in_one_line(fillet_file, tmp_path, faces, words):
    r = _cli("flatten", fillet_file, f"--faces={faces}", "--spacing", "2", "--out", tmp_path / "r.json")
    assert r.returncode == 2 and words in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr


@pytest.mark.slow
def test_cli_refuses_faces_with_face_region_or_a_non_cad_file(fillet_file, tmp_path):
    out = tmp_path / "r.json"
    r = _cli("flatten", fillet_file, "--faces", "0,1", "--face", "0", "--spacing", "2", "--out", out)
    assert r.returncode == 2 and "not both" in r.stderr
    region = tmp_path / "region.json"
    region.write_text(json.dumps({"uv": [[0.2, 0.2], [0.8, 0.2], [0.8, 0.8]]}))
    r = _cli("flatten", fillet_file, "--faces", "0,1", "--region", region, "--spacing", "2", "--out", out)
    assert r.returncode == 2 and "their outline" in r.stderr
    r = _cli("flatten", "octant", "--faces", "0,1", "--spacing", "0.1", "--out", out)
    assert r.returncode == 2 and "for STEP and IGES files" in r.stderr


# ---------------------------------------------------------------------- projects
def test_project_of_joined_faces_reopens_without_the_file(fillet_piece, tmp_path):
    from flatweave.geometry.meshfit import FittedSurface
    from flatweave.document.project import load_project, new_project, project_to_dict, save_project
    cad, piece = fillet_piece
    project = new_project(piece.surface, "part faces 0,1,2", f"{cad.path}#faces=0,1,2", units="mm",
                          region=piece.region)
    saved = save_project(project, tmp_path / "part.flatweave")
    again = load_project(saved)  # the CAD file is not read: the project holds the fitted surface and its faces
    assert isinstance(again.surface, FittedSurface)
    assert again.surface.fit == piece.fit and again.surface.fit.faces == (0, 1, 2)
    assert np.array_equal(again.surface.ctrlpts, piece.surface.ctrlpts)
    assert again.settings.region == piece.region and again.source == project.source
    assert project_to_dict(again)["sources"][0]["surface_fit"]["faces"] == [0, 1, 2]


def test_densify_keeps_the_shape_and_bounds_the_edges():
    """Two triangles of a 40 x 1 rectangle and a fan: after densify no edge is
    longer than h, the area and the boundary are the same, the mesh is one
    manifold piece wound as before."""
    from flatweave.geometry.meshfit import edge_table, boundary_loops, clean_mesh, densify
    V = np.array([[0, 0, 0], [40, 0, 0], [40, 1, 0], [0, 1, 0], [20, 30, 0]], float)
    F = np.array([[0, 1, 2], [0, 2, 3], [3, 2, 4]])
    V2, F2, _ = densify(V, F, 0.7)
    uniq, _, _ = edge_table(F2)
    assert np.linalg.norm(V2[uniq[:, 0]] - V2[uniq[:, 1]], axis=1).max() <= 0.7 + 1e-12
    a, b, c = V2[F2[:, 0]], V2[F2[:, 1]], V2[F2[:, 2]]
    cross = np.cross(b - a, c - a)
    assert np.all(cross[:, 2] > 0)  # the winding kept, no triangle flat
    assert 0.5 * cross[:, 2].sum() == pytest.approx(40 + 0.5 * 40 * 29)
    V3, F3, _ = clean_mesh(V2, F2)
    loops = boundary_loops(F3)
    assert len(loops) == 1
    ring = V3[loops[0]]
    perimeter = np.linalg.norm(ring - np.roll(ring, -1, axis=0), axis=1).sum()
    assert perimeter == pytest.approx(40 + 1 + 1 + 2 * math.hypot(20, 29))


def test_densify_lifts_new_points_onto_a_cylinder_by_the_normals():
    """A strip of a cylinder of radius 8 in triangles 0.1 rad wide and 25 long: split
    on the chords the new points sink by the sagitta (8 (1 - cos 0.05) = 0.01); lifted
    by the exact normals they stay on the cylinder to the fourth order (< 1e-5)."""
    from flatweave.geometry.meshfit import densify
    a = np.linspace(0, 0.5, 6)
    ring = np.stack([8 * np.cos(a), 8 * np.sin(a)], axis=1)
    V = np.vstack([np.c_[ring, np.zeros(6)], np.c_[ring, np.full(6, 25.0)]])
    N = np.vstack([np.c_[np.cos(a), np.sin(a), np.zeros(6)]] * 2)
    F = np.array([t for k in range(5) for t in ((k, k + 1, k + 7), (k, k + 7, k + 6))])
    for normals, worst in ((None, 8 * (1 - math.cos(0.05))), (N, 1e-5)):
        V2, F2, N2 = densify(V, F, 0.3, normals=normals)
        r = np.hypot(V2[:, 0], V2[:, 1])
        assert len(V2) > 10 * len(V) and abs(r - 8).max() <= worst * (1 + 1e-9)
    np.testing.assert_allclose(np.linalg.norm(N2, axis=1), 1.0)
    np.testing.assert_allclose(N2[:, :2] / np.linalg.norm(N2[:, :2], axis=1)[:, None],
                               V2[:, :2] / np.linalg.norm(V2[:, :2], axis=1)[:, None], atol=1e-4)
    # (the new normals are interpolated, not the surface's: they agree to the order of the angle cubed)
