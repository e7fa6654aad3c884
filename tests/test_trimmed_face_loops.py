"""A trimmed CAD face's loops follow the surface, in the result file's ``region``.

The face is made with Open CASCADE (tests/cadfiles.py, ``face_straight_trims``): a wavy B-spline
surface trimmed by a quadrilateral with a triangular hole, every trim edge a line in (u, v), so that
each edge's 3D curve bends with the surface while the loops in (u, v) are its corners alone.
It is written to IGES (as B-rep faces and as trimmed surfaces) and STEP and read back by
flatweave.reading.cad. The oracle is Open CASCADE in this process: the face's own surface, evaluated at the
record's (u, v), and its edges' 3D curves (``BRepAdaptor_Curve``), sampled finely.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from flatweave.geometry.region import LOOP_CHORD_TOL, loops_on_surface, region_from_cad_face, region_record

from tests.helpers import needs_ocp
pytestmark = needs_ocp

EDGE_SAMPLES = 2001  # points per OCC edge curve: its own chords are ~1e-6 mm off it, far below the tolerances


def occ_edge_curves(shape) -> list[np.ndarray]:
    """Each edge's 3D curve (``BRepAdaptor_Curve``: the edge's own 3D curve) of a face or wire,
    EDGE_SAMPLES points."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    from tests.cadfiles import _static
    out, ex = [], TopExp_Explorer(shape, TopAbs_EDGE)
    while ex.More():
        c = BRepAdaptor_Curve(_static(TopoDS, "Edge")(ex.Current()))
        pts = [c.Value(float(t)) for t in np.linspace(c.FirstParameter(), c.LastParameter(), EDGE_SAMPLES)]
        out.append(np.array([(p.X(), p.Y(), p.Z()) for p in pts]))
        ex.Next()
    return out


def occ_surface_points(face, uv: np.ndarray) -> np.ndarray:
    """The face's own surface (OCC) at (u, v)."""
    from OCP.BRep import BRep_Tool

    from tests.cadfiles import _static
    s = _static(BRep_Tool, "Surface")(face)
    return np.array([(p.X(), p.Y(), p.Z()) for p in (s.Value(float(u), float(v)) for u, v in uv)])


def occ_surface_distance(face, xyz: np.ndarray) -> np.ndarray:
    """Distance of points to the face's own surface (OCC's projection)."""
    from OCP.BRep import BRep_Tool
    from OCP.GeomAPI import GeomAPI_ProjectPointOnSurf
    from OCP.gp import gp_Pnt

    from tests.cadfiles import _static
    s = _static(BRep_Tool, "Surface")(face)
    return np.array([GeomAPI_ProjectPointOnSurf(gp_Pnt(*map(float, p)), s).LowerDistance() for p in xyz])


def segment_distance(points: np.ndarray, loops) -> np.ndarray:
    """Distance of each point to the nearest chord of the closed polylines ``loops``."""
    a = np.vstack(loops)
    b = np.vstack([np.roll(p, -1, axis=0) for p in loops])
    ab, ap = b - a, points[:, None, :] - a[None]
    t = np.clip(np.einsum("ijk,jk->ij", ap, ab) / np.maximum(np.einsum("jk,jk->j", ab, ab), 1e-300), 0, 1)
    r = ap - t[..., None] * ab
    return np.sqrt(np.min(np.einsum("ijk,ijk->ij", r, r), axis=1))


def chord_gap(loops, curves) -> tuple[float, float]:
    """(largest distance of OCC's edge curves from the loops' chords, largest distance of the loops'
    points from OCC's edge curves)."""
    samples = np.vstack(curves)
    a = np.vstack([c[:-1] for c in curves])  # each edge an open polyline of EDGE_SAMPLES points
    b = np.vstack([c[1:] for c in curves])
    pts = np.vstack(loops)
    ab, ap = b - a, pts[:, None, :] - a[None]
    t = np.clip(np.einsum("ijk,jk->ij", ap, ab) / np.maximum(np.einsum("jk,jk->j", ab, ab), 1e-300), 0, 1)
    r = ap - t[..., None] * ab
    on_curve = np.sqrt(np.min(np.einsum("ijk,ijk->ij", r, r), axis=1))
    return float(segment_distance(samples, loops).max()), float(on_curve.max())


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """(the OCC face, its edges' 3D curves, {format: the CadFace read back})."""
    from flatweave.reading.cad import read_cad_faces
    from tests import cadfiles as cf

    tmp = tmp_path_factory.mktemp("straight")
    face = cf.face_straight_trims()
    paths = {"iges": cf.write_iges(face, tmp / "straight.igs"),
             "iges144": cf.write_iges(face, tmp / "straight144.igs", brep=False),
             "step": cf.write_step(face, tmp / "straight.step")}
    read = {}
    for fmt, path in paths.items():
        (f,) = read_cad_faces(path).faces
        read[fmt] = f
    return face, occ_edge_curves(face), read


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["iges", "iges144", "step"])
def test_the_trims_are_their_corners_in_uv(made, fmt):
    """What the reader gives is the file's: each loop is its corners alone (the edges are lines in
    (u, v)), so drawing those points joined by chords would cut through the surface."""
    face, curves, read = made
    f = read[fmt]
    assert f.trimmed and not f.reversed
    np.testing.assert_allclose(f.surface.domain, [[0, 1], [0, 1]])
    assert [len(p) for p in f.loops_uv] == [4, 3]
    corners = [f.surface.points(p) for p in f.loops_uv]
    chord_off, _ = chord_gap(corners, curves)
    diag = float(np.linalg.norm(np.ptp(np.vstack(curves), axis=0)))
    assert chord_off > 100 * LOOP_CHORD_TOL * diag  # the oracle tells corners from curves


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["iges", "iges144", "step"])
def test_result_region_loops_follow_the_edges(made, fmt):
    """The result file's ``region.loops_xyz`` lies on the surface at ``loops_uv`` and along OCC's
    3D edge curves: every OCC curve point within the chord tolerance of the loops' chords, every
    loop point on a curve, many points per edge; ``loops_uv`` keeps the region's corners in order
    and adds points on its sides only."""
    face, curves, read = made
    f = read[fmt]
    region = region_from_cad_face(f)
    rec = json.loads(json.dumps(region_record(f.surface, region)))  # as the result file holds it
    assert rec["drawn"] is None and len(rec["loops_uv"]) == len(rec["loops_xyz"]) == 2
    uvs = [np.asarray(p, float) for p in rec["loops_uv"]]
    xyzs = [np.asarray(p, float) for p in rec["loops_xyz"]]
    diag = float(np.linalg.norm(np.ptp(np.vstack(xyzs), axis=0)))
    for uv, xyz, own in zip(uvs, xyzs, region.arrays()):
        assert uv.shape[0] == xyz.shape[0] >= 10 * len(own)  # the corners alone were 4 and 3
        # on the surface: OCC's own surface at the record's (u, v) is the record's point
        np.testing.assert_allclose(occ_surface_points(face, uv), xyz, rtol=0, atol=1e-9 * diag)
        # the region's own points, in order, and the rest on its sides in (u, v)
        at = [int(np.flatnonzero(np.all(uv == q, axis=1))[0]) for q in own]
        assert at[0] == 0 and np.all(np.diff(at) > 0)
        assert segment_distance(np.column_stack([uv, np.zeros(len(uv))]),
                                [np.column_stack([own, np.zeros(len(own))])]).max() < 1e-12
    chord_off, point_off = chord_gap(xyzs, curves)
    bound = LOOP_CHORD_TOL * diag + f.trim_deviation
    assert chord_off <= bound, (chord_off, bound)
    assert point_off <= f.trim_deviation + 1e-6 * diag, (point_off, f.trim_deviation)


@pytest.mark.slow
def test_loops_sampled_to_the_tolerance_asked(made):
    """A finer tolerance gives more points and chords closer to OCC's curves, still within it."""
    face, curves, read = made
    f = read["iges"]
    region = region_from_cad_face(f)
    diag = None
    counts = []
    for rel in (1e-3, 1e-4, 1e-5):
        loops = loops_on_surface(f.surface, region, rel)
        xyz = [p for _, p in loops]
        diag = float(np.linalg.norm(np.ptp(np.vstack(xyz), axis=0)))
        chord_off, _ = chord_gap(xyz, curves)
        assert chord_off <= rel * diag + f.trim_deviation, (rel, chord_off)
        counts.append(sum(len(p) for p in xyz))
    assert counts[0] <= counts[1] < counts[2]


def test_result_file_of_a_flattened_face(made, tmp_path):
    """Through the pipeline: the result file's region of a flattened IGES face is the sampled one."""
    from flatweave.method.settings import FlattenSettings
    from flatweave.method.pipeline import flatten
    from flatweave.method.result import result_to_dict

    face, curves, read = made
    f = read["iges"]
    region = region_from_cad_face(f)
    from flatweave.geometry.region import cover_for
    cover = cover_for(f.surface, region)
    result = flatten(f.surface, FlattenSettings(spacing=2.5, region=region, seed=cover.default_seed))
    rec = result_to_dict(result)["region"]
    xyzs = [np.asarray(p, float) for p in rec["loops_xyz"]]
    assert [len(p) for p in xyzs] == [len(p) for p in rec["loops_uv"]] and min(len(p) for p in xyzs) > 40
    diag = float(np.linalg.norm(np.ptp(np.vstack(xyzs), axis=0)))
    chord_off, _ = chord_gap(xyzs, curves)
    assert chord_off <= LOOP_CHORD_TOL * diag + f.trim_deviation
