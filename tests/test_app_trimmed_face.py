"""The window draws a trimmed CAD face as the piece only, its loops along the surface.

The face (tests/cadfiles.py, ``face_straight_trims``) is a wavy B-spline surface trimmed by a
quadrilateral with a triangular hole whose edges are lines in (u, v) and curves in space,
written to IGES and opened in the window. Open CASCADE, in this process, is the oracle: the
face's edges' 3D curves, its surface (projection) and its classifier (which side of the trim a
point of the surface is on), and its area (``BRepGProp``).

The surface outside the trim is hidden, not drawn faint: the guide (docs/guide/composite-ply-from-step.md)
promises the piece only, a CAD surface is often extended far beyond its trims (the rest would fill the view and its
framing), and a translucent sheet over or under the mesh would blur the strain colours. A
region the designer drew keeps the whole surface in sight, to edit the boundary on it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from flatweave.geometry.region import LOOP_CHORD_TOL
from tests.test_trimmed_face_loops import chord_gap, occ_edge_curves, occ_surface_distance

from tests.helpers import needs_ocp
pytestmark = needs_ocp

GRID_CELLS = 59 * 59  # the whole surface's quads (flatweave.app.presenter.GRID_POINTS = 60)


@pytest.fixture(scope="module")
def straight_iges(tmp_path_factory):
    """(the OCC face, the IGES file it was written to)."""
    from tests import cadfiles as cf

    face = cf.face_straight_trims()
    return face, cf.write_iges(face, tmp_path_factory.mktemp("straight") / "straight.igs")


def occ_sides(face, xyz: np.ndarray, tol: float) -> np.ndarray:
    """(n,) str, where each point of the face's surface lies: "IN", "ON" (within ``tol`` of the
    trim, in (u, v)) or "OUT", by OCC's projection onto the surface and its face classifier."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepClass import BRepClass_FaceClassifier
    from OCP.GeomAPI import GeomAPI_ProjectPointOnSurf
    from OCP.gp import gp_Pnt, gp_Pnt2d

    from tests.cadfiles import _static
    s = _static(BRep_Tool, "Surface")(face)
    out = []
    for p in xyz:
        u, v = GeomAPI_ProjectPointOnSurf(gp_Pnt(*map(float, p)), s).LowerDistanceParameters()
        out.append(BRepClass_FaceClassifier(face, gp_Pnt2d(u, v), tol).State().name.removeprefix("TopAbs_"))
    return np.array(out)


def drawn_surface(view) -> tuple[np.ndarray, np.ndarray]:
    """(points (n, 3), triangles (t, 3)) of the surface the 3D view draws (its quads halved)."""
    mesh = view._surface.triangulate()
    return np.asarray(mesh.points), np.asarray(mesh.regular_faces)


def mesh_area(points: np.ndarray, triangles: np.ndarray) -> float:
    a, b, c = (points[triangles[:, k]] for k in range(3))
    return float(0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())


@pytest.mark.slow
def test_a_trimmed_iges_face_is_drawn_as_the_piece_with_its_edges(make_window, straight_iges):
    """Opened from IGES (its region not drawn): the loops drawn follow OCC's edge curves on the
    surface, and the surface drawn is the piece, none of it outside the trim."""
    from flatweave.reading.cad import read_cad_faces
    from flatweave.geometry.region import region_from_cad_face
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    from flatweave.app.presenter import piece_grid
    from tests.cadfiles import _static

    face, path = straight_iges
    curves = occ_edge_curves(face)
    win = make_window()
    assert win.open_file(path)
    region = win.project.settings.region
    assert region is not None and region.drawn is None and region.n_holes == 1
    assert [len(p) for p in region.loops] == [4, 3]  # the file's trims: their corners in (u, v)

    # (1) the black loops follow OCC's 3D edges, on the surface, with many points
    loops = win.view.loops
    assert len(loops) == 2 and len(loops[0]) >= 40 and len(loops[1]) >= 30
    diag = float(np.linalg.norm(np.ptp(np.vstack(loops), axis=0)))
    assert occ_surface_distance(face, np.vstack(loops)).max() <= 1e-7 * diag
    chord_off, point_off = chord_gap(loops, curves)
    assert chord_off <= LOOP_CHORD_TOL * diag + 1e-6 * diag, chord_off
    assert point_off <= 1e-6 * diag
    assert chord_gap([win.surface.points(p) for p in region.arrays()], curves)[0] > 100 * chord_off

    # (2) the surface drawn is the piece: no point of it outside the trim, its area the face's
    points, triangles = drawn_surface(win.view)
    used = np.unique(triangles)
    sides = occ_sides(face, points[used], 1e-7)
    assert set(sides) <= {"IN", "ON"}, np.unique(sides, return_counts=True)
    props = GProp_GProps()
    _static(BRepGProp, "SurfaceProperties")(face, props, 1e-10)
    assert mesh_area(points, triangles) == pytest.approx(props.Mass(), rel=2e-4)  # the grid's quads: 1.9e-3
    assert 0 < win.view.kept_cells < GRID_CELLS

    # the quads whose centres lie in the region (piece_grid, the face picker's rule) are not
    # the piece: some of their corners lie outside the trim, so the check above can tell
    f = read_cad_faces(path).faces[0]
    _, xyz, _, keep, _ = piece_grid(f.surface, region_from_cad_face(f))
    n = xyz.shape[0]
    idx = np.arange(n * n).reshape(n, n)
    corners = np.stack([idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]], axis=-1)[keep]
    assert "OUT" in set(occ_sides(face, xyz.reshape(-1, 3)[np.unique(corners)], 1e-7))


def test_a_drawn_region_keeps_the_whole_surface_in_sight(make_window, straight_iges):
    """The same quadrilateral drawn by the designer (a region in fractions of the domain): the
    whole surface stays drawn, to edit the boundary on it, and its loop follows the surface."""
    from OCP.BRepTools import BRepTools

    from flatweave.geometry.region import cover_for, region_from_spec
    from tests import cadfiles as cf
    from tests.cadfiles import _static

    face, path = straight_iges
    win = make_window()
    assert win.open_file(path)
    drawn = region_from_spec(win.surface, {"uv": cf.STRAIGHT_OUTER})
    assert drawn.drawn is not None and len(drawn.loops[0]) == 4
    win.document.edit_settings("Draw region", region=drawn, seed=cover_for(win.surface, drawn).default_seed)
    assert win.project.settings.region is drawn
    assert win.view.kept_cells == GRID_CELLS
    (loop,) = win.view.loops
    assert len(loop) >= 40
    diag = float(np.linalg.norm(np.ptp(loop, axis=0)))
    assert occ_surface_distance(face, loop).max() <= 1e-7 * diag
    chord_off, _ = chord_gap([loop], occ_edge_curves(_static(BRepTools, "OuterWire")(face)))
    assert chord_off <= LOOP_CHORD_TOL * diag + 1e-6 * diag
    # a CAD face again: the piece only
    win.document.edit_settings("Region", region=replace(drawn, drawn=None))
    assert win.view.kept_cells < GRID_CELLS
