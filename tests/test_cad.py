"""Reading STEP and IGES faces (flatweave.reading.cad) against Open CASCADE itself.

The files are written by Open CASCADE in the test (tests/cadfiles.py) and
read back by flatweave.reading.cad in its child process; the oracle is Open CASCADE in
this process: its evaluation of the converted surfaces, its 3D edges and its
``BRepGProp`` areas. Tests of the paths without Open CASCADE (bad names,
empty or binary files, a missing OCP) run everywhere; the others are skipped,
saying why, only when OCP cannot be imported.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from flatweave.reading.cad import (CadFileError, CadUnavailableError, INSTALL_HINT, cad_info, face_table,
                      read_cad_faces)
from flatweave.errors import FlatweaveError, SettingsError
from flatweave.geometry.uvregion import region_area

from tests.helpers import HAVE_OCP, needs_ocp

BAD = Path(__file__).parent / "data" / "bad"
ROOT = Path(__file__).resolve().parent.parent

# what the measurements below found, printed by -s (and summarised in the report)
MEASURED: dict[str, float] = {}


def _record(key: str, value: float) -> None:
    MEASURED[key] = max(MEASURED.get(key, 0.0), float(value))


# ====================================================================== files
# faces of the main test compound, in the order tests/cadfiles.py builds them
MAIN_FACES = ["face_circle_hole", "face_free_outer", "face_mixed_outer", "face_rational_hole",
              "face_reversed", "face_periodic_bspline"]


@pytest.fixture(scope="module")
def cf():
    if not HAVE_OCP:
        pytest.skip("Open CASCADE is not installed (pip install cadquery-ocp-novtk)")
    from tests import cadfiles
    return cadfiles


@pytest.fixture(scope="module")
def files(cf, tmp_path_factory):
    """Every test file, written once: name -> path."""
    d = tmp_path_factory.mktemp("cad")
    main = cf.compound(*[getattr(cf, n)() for n in MAIN_FACES], cf.cylinder_solid(), cf.analytic_solids())
    out = {
        "main.step": cf.write_step(main, d / "main.step", schema="AP214IS"),
        "main.igs": cf.write_iges(main, d / "main.igs", brep=True),
        "main144.iges": cf.write_iges(main, d / "main144.iges", brep=False),
        "assembly.step": cf.write_step(cf.placed_compound(), d / "assembly.step", schema="AP242DIS", assembly=True),
        "placed.igs": cf.write_iges(cf.placed_compound(cf.face_rational_hole()), d / "placed.igs"),
        "seam.stp": cf.write_step(seam_face(cf), d / "seam.stp", schema="AP203"),
        "metre.step": cf.write_step(cf.face_circle_hole(), d / "metre.step", unit="M", schema="AP203"),
        "inch.step": cf.write_step(cf.face_circle_hole(), d / "inch.step", unit="INCH", schema="AP242DIS"),
        "mm.step": cf.write_step(cf.face_circle_hole(), d / "mm.step", unit="MM", schema="AP242DIS"),
        "metre.igs": cf.write_iges(cf.face_rational_hole(), d / "metre.igs", unit="M"),
        "curve.igs": cf.write_iges_curve_only(d / "curve.igs"),
        "sticking.step": cf.write_step(cf.compound(*cf.faces_sticking_out()), d / "sticking.step"),
    }
    return out


def seam_face(cf):
    """A face on a u-periodic B-spline (knots 0..8) whose u-range 5.5..12
    crosses the end of the knot range (OCCT's whole-shape NURBS conversion
    refuses it; it is read as the B-spline it is)."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    s = cf._static(BRep_Tool, "Surface")(cf.face_periodic_bspline())
    return BRepBuilderAPI_MakeFace(s, 5.5, 12.0, 0.0, 1.0, 1e-9).Face()


_READS: dict[str, object] = {}


def read(files, name: str):
    """flatweave.reading.cad's reading of a test file (each file read once per session)."""
    key = str(files[name])
    if key not in _READS:
        _READS[key] = read_cad_faces(files[name])
    return _READS[key]


# ---------------------------------------------------------------------- the oracle
class Occ:
    """Open CASCADE's own reading of a file, in this process: the converted
    faces (TopExp_Explorer order) whose surfaces and edges are the oracle."""

    def __init__(self, path: Path, mm_per_unit: float = 1.0):
        from OCP.BRepBuilderAPI import BRepBuilderAPI_NurbsConvert
        from OCP.IGESControl import IGESControl_Reader
        from OCP.STEPControl import STEPControl_Reader
        from OCP.TopAbs import TopAbs_FACE
        from OCP.TopExp import TopExp_Explorer
        from OCP.TopoDS import TopoDS

        from tests.cadfiles import _static
        if path.suffix.lower() in (".step", ".stp"):
            r = STEPControl_Reader()
            r.ReadFile(str(path))
            r.SetSystemLengthUnit(mm_per_unit)
        else:
            r = IGESControl_Reader()
            r.ReadFile(str(path))
            gs = r.IGESModel().GlobalSection()
            gs.SetCascadeUnit(mm_per_unit)
            r.IGESModel().SetGlobalSection(gs)
        r.TransferRoots()
        self.shape = r.OneShape()
        as_face = _static(TopoDS, "Face")

        def faces(shape):
            out, ex = [], TopExp_Explorer(shape, TopAbs_FACE)
            while ex.More():
                out.append(as_face(ex.Current()))
                ex.Next()
            return out

        self.originals = faces(self.shape)
        try:
            self.faces = faces(BRepBuilderAPI_NurbsConvert(self.shape, True).Shape())
        except Exception:  # the seam face: its B-spline is used as it is
            self.faces = self.originals

    def surface_points(self, i: int, uv: np.ndarray) -> np.ndarray:
        from OCP.BRep import BRep_Tool

        from tests.cadfiles import _static
        s = _static(BRep_Tool, "Surface")(self.faces[i])
        out = np.empty((len(uv), 3))
        for k, (u, v) in enumerate(uv):
            p = s.Value(float(u), float(v))
            out[k] = (p.X(), p.Y(), p.Z())
        return out

    def face_normals(self, i: int, uv: np.ndarray) -> np.ndarray:
        """Unit normals of the face (its orientation applied) at OCC's (u, v)."""
        from OCP.BRepGProp import BRepGProp_Face
        from OCP.gp import gp_Pnt, gp_Vec
        f = BRepGProp_Face(self.faces[i])
        out = np.empty((len(uv), 3))
        for k, (u, v) in enumerate(uv):
            p, n = gp_Pnt(), gp_Vec()
            f.Normal(float(u), float(v), p, n)
            out[k] = (n.X(), n.Y(), n.Z())
        return out / np.linalg.norm(out, axis=1)[:, None]

    def edges(self, i: int) -> list:
        """(curve, first, last) of each non-degenerate edge, and the vertices."""
        from OCP.BRep import BRep_Tool
        from OCP.TopAbs import TopAbs_EDGE, TopAbs_VERTEX
        from OCP.TopExp import TopExp_Explorer
        from OCP.TopoDS import TopoDS

        from tests.cadfiles import _static
        curves, verts = [], []
        ex = TopExp_Explorer(self.faces[i], TopAbs_EDGE)
        while ex.More():
            e = _static(TopoDS, "Edge")(ex.Current())
            if not _static(BRep_Tool, "Degenerated")(e):
                c = _static(BRep_Tool, "Curve")(e, 0.0, 0.0)
                t0, t1 = _static(BRep_Tool, "Range")(e)
                curves.append((c, t0, t1))
            ex.Next()
        ex = TopExp_Explorer(self.faces[i], TopAbs_VERTEX)
        while ex.More():
            p = _static(BRep_Tool, "Pnt")(_static(TopoDS, "Vertex")(ex.Current()))
            verts.append((p.X(), p.Y(), p.Z()))
            ex.Next()
        return curves, np.array(verts)


def occ_area(shape) -> float:
    """BRepGProp's area of a shape (adaptive, to 1e-10 relative)."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    from tests.cadfiles import _static
    props = GProp_GProps()
    _static(BRepGProp, "SurfaceProperties")(shape, props, 1e-10)
    return props.Mass()


def distance_to_edges(points: np.ndarray, curves, verts: np.ndarray) -> np.ndarray:
    """Distance of each point to the nearest edge curve (or vertex)."""
    from OCP.GeomAPI import GeomAPI_ProjectPointOnCurve
    from OCP.gp import gp_Pnt
    out = np.full(len(points), np.inf)
    if len(verts):
        out = np.min(np.linalg.norm(points[:, None, :] - verts[None, :, :], axis=2), axis=1)
    for c, t0, t1 in curves:
        ends = []
        for t in (t0, t1):
            q = c.Value(t)
            ends.append((q.X(), q.Y(), q.Z()))
        out = np.minimum(out, np.min(np.linalg.norm(points[:, None, :] - np.array(ends)[None], axis=2), axis=1))
        for k, p in enumerate(points):
            proj = GeomAPI_ProjectPointOnCurve(gp_Pnt(*p), c, t0, t1)
            if proj.NbPoints():
                out[k] = min(out[k], proj.LowerDistance())
    return out


def occ_uv(face, uv: np.ndarray) -> np.ndarray:
    """OCC's (u, v) of our (u, v): u -> a + b - u on a reversed face."""
    if not face.reversed:
        return uv
    (a, b), _ = face.surface.domain
    return np.column_stack([a + b - uv[:, 0], uv[:, 1]])


def random_uv(face, n: int = 200, seed: int = 0) -> np.ndarray:
    d = face.surface.domain
    rng = np.random.default_rng(seed + face.index)
    return np.column_stack([rng.uniform(d[0, 0], d[0, 1], n), rng.uniform(d[1, 0], d[1, 1], n)])


def signed_area(p: np.ndarray) -> float:
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


# ====================================================================== what is read
# the faces of main.* by their areas (OCCT's writers put the solids first)
AREAS = {"circle_hole": 1145.644944594528, "free": 356.7399429595424, "mixed": 304.5664709003275,
         "rational": 907.1218018030422, "tube": 1309.4785500035905, "cylinder": 376.99111843077515,
         "sphere": 615.7521601035994}
MAIN_KINDS = sorted(["bspline"] * 6 + ["cylinder", "plane", "plane"] + ["plane"] * 6
                    + ["sphere", "cone", "plane", "torus"])


def named(cad) -> dict:
    """Faces of main.* by name; "free" and "reversed" share an area (the
    reversed one comes second)."""
    out = {}
    for name, area in AREAS.items():
        hits = [f for f in cad.faces if f.area == pytest.approx(area, rel=1e-7)]
        assert len(hits) == (2 if name == "free" else 1), name
        out[name] = hits[0]
        if name == "free":
            out["reversed"] = hits[1]
    return out


def occ_kind(face) -> str:
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from flatweave.reading.cad import _KINDS
    return _KINDS[BRepAdaptor_Surface(face, False).GetType().name]


@pytest.mark.slow
@needs_ocp
@pytest.mark.parametrize("name", ["main.step", "main.igs", "main144.iges"])
def test_faces_kinds_and_flags(files, name):
    cad, occ = read(files, name), Occ(files[name])
    assert cad.units == "mm" and cad.mm_per_unit == 1.0
    assert [f.index for f in cad.faces] == list(range(len(MAIN_KINDS)))
    # OCC's TopExp_Explorer order, each face's kind the file's
    assert [f.kind for f in cad.faces] == [occ_kind(f) for f in occ.originals]
    kinds = sorted(f.kind for f in cad.faces)
    if name == "main144.iges":  # trimmed-surface IGES: analytic faces are surfaces of revolution
        assert kinds == sorted(["bspline"] * 6 + ["plane"] * 9 + ["revolution"] * 4)
    else:
        assert kinds == MAIN_KINDS
    f = named(cad)
    assert [len(f[n].loops_uv) - 1 for n in ("circle_hole", "free", "mixed", "rational", "reversed", "tube")] \
        == [1, 2, 0, 1, 2, 0]
    assert all(f[n].trimmed for n in ("circle_hole", "free", "mixed", "rational", "reversed"))
    assert not any(f[n].trimmed for n in ("tube", "cylinder", "sphere"))
    box = [g for g in cad.faces if g.kind == "plane" and round(g.area) in (600, 300, 200)]
    caps = [g for g in cad.faces if g.kind == "plane" and round(g.area, 2) in (78.54, 113.1)]
    assert len(box) == 6 and not any(g.trimmed for g in box)
    assert len(caps) == 3 and all(g.trimmed for g in caps)  # a circle in a plane's rectangle
    if name == "main.step":  # IGES keeps no orientation of a lone face
        assert f["reversed"].reversed and not f["free"].reversed
        assert sum(g.reversed for g in box) == 3
    for g in cad.faces:
        assert g.tolerance > 0 and len(g.loops_uv) == len(g.loop_breaks) >= 1
        assert len(g.bbox) == 6 and all(g.bbox[k] <= g.bbox[k + 3] for k in range(3))


@pytest.mark.slow
@needs_ocp
@pytest.mark.parametrize("name", ["main.step", "main.igs", "main144.iges", "assembly.step", "placed.igs", "seam.stp",
                                  "sticking.step"])
def test_surface_agrees_with_occ(files, name):
    cad, occ = read(files, name), Occ(files[name])
    assert len(occ.faces) == len(cad.faces)
    worst = 0.0
    for f in cad.faces:
        uv = random_uv(f)
        ours = f.surface.points(uv)
        theirs = occ.surface_points(f.index, occ_uv(f, uv))
        worst = max(worst, float(np.max(np.linalg.norm(ours - theirs, axis=1))))
    _record("surface deviation from OCC", worst)
    assert worst <= 1e-9


@needs_ocp
@pytest.mark.parametrize("name", ["main.step", "main.igs", "assembly.step", "seam.stp"])
def test_normals_are_the_faces(files, name):
    """Su x Sv is the face's normal (BRepGProp_Face applies its orientation)."""
    cad, occ = read(files, name), Occ(files[name])
    for f in cad.faces:
        uv = random_uv(f, 50)
        ev = f.surface.evaluate(uv)
        ok = np.linalg.norm(np.cross(ev.su, ev.sv), axis=1) > 1e-9 * f.surface.bbox_diagonal() ** 2
        theirs = occ.face_normals(f.index, occ_uv(f, uv))
        assert np.all(np.einsum("ij,ij->i", ev.normal[ok], theirs[ok]) > 1 - 1e-9), f.index


@needs_ocp
@pytest.mark.parametrize("name", ["main.step", "main.igs"])
def test_solid_normals_point_outward(files, name):
    """On the closed solids the normals point out: a check by geometry alone."""
    from shapely import Polygon, contains_xy
    cad = read(files, name)
    cyl_axis, sphere_c = np.array([1.0, 2.0]), np.zeros(3)
    cone_apex, torus_c = np.array([20, 0, 9.0]), np.array([0, 30, 0.0])
    centres = {600: [-25, 10, 15.0], 300: [-25, 10, 15.0], 200: [-25, 10, 15.0], 79: [1, 2, 9.0], 113: [20, 0, 3.0]}
    checked = 0
    for f in cad.faces:
        if f.kind == "bspline":
            continue
        uv = random_uv(f, 40)
        inside = contains_xy(Polygon(f.loops_uv[0]), uv[:, 0], uv[:, 1])
        ev = f.surface.evaluate(uv[inside])
        P, n = ev.xyz, ev.normal
        if f.kind == "sphere":
            out = P - sphere_c
        elif f.kind == "torus":  # away from the core circle (radius 8 about the y axis)
            r = np.hypot(P[:, 0], P[:, 2])[:, None]
            core = np.column_stack([P[:, 0], np.zeros(len(P)), P[:, 2]]) * (8.0 / r) + torus_c
            out = P - core
        elif f.kind == "cylinder":
            out = np.column_stack([P[:, 0] - cyl_axis[0], P[:, 1] - cyl_axis[1], np.zeros(len(P))])
        elif f.kind == "cone":
            out = np.column_stack([P[:, 0] - cone_apex[0], P[:, 1], np.zeros(len(P))])
        else:  # planes: from the solid's centre
            out = P - np.array(centres[round(f.area)])
        assert len(P) >= 10 and np.all(np.einsum("ij,ij->i", n, out) > 0), (f.index, f.kind)
        checked += 1
    assert checked == 13


@pytest.mark.slow
@needs_ocp
@pytest.mark.parametrize("name", ["main.step", "main.igs", "main144.iges", "assembly.step", "placed.igs", "seam.stp"])
def test_loops_lie_on_the_face(files, name):
    """Loop points mapped by our surface lie on OCC's 3D edges within the
    face's tolerance; the corners are vertices; outer counter-clockwise,
    holes clockwise, inside the domain."""
    cad, occ = read(files, name), Occ(files[name])
    worst_ratio = worst_abs = over = 0.0
    for f in cad.faces:
        curves, verts = occ.edges(f.index)
        d = f.surface.domain
        for k, (loop, breaks) in enumerate(zip(f.loops_uv, f.loop_breaks)):
            assert loop.ndim == 2 and loop.shape[1] == 2 and len(loop) >= 3
            assert np.all(loop[:, 0] >= d[0, 0]) and np.all(loop[:, 0] <= d[0, 1])
            assert np.all(loop[:, 1] >= d[1, 0]) and np.all(loop[:, 1] <= d[1, 1])
            assert (signed_area(loop) > 0) == (k == 0), (f.index, k)
            assert breaks[0] == 0 and np.all(np.diff(breaks) > 0) and breaks[-1] < len(loop)
            pick = np.unique(np.r_[np.linspace(0, len(loop) - 1, 60).astype(int), breaks])
            dist = distance_to_edges(f.surface.points(loop[pick]), curves, verts)
            # the trims are as accurate as the file: its stated tolerance, or the
            # deviation of its pcurves from its 3D edges where that is larger
            bound = max(f.tolerance, f.trim_deviation)
            worst_ratio = max(worst_ratio, float(np.max(dist) / bound))
            worst_abs = max(worst_abs, float(np.max(dist)))
            assert np.all(dist <= 1.25 * bound + 1e-12), (f.index, k, float(np.max(dist)), f.tolerance, bound)
            corner = np.min(np.linalg.norm(f.surface.points(loop[breaks])[:, None] - verts[None], axis=2), axis=1)
            assert np.all(corner <= 1.01 * f.tolerance + 1e-12), (f.index, k)
        over = max(over, f.trim_deviation / f.tolerance)
    _record("loop distance / max(tolerance, trim deviation)", worst_ratio)
    _record("loop distance to OCC 3D edges (mm)", worst_abs)
    _record("file trim deviation / stated tolerance", over)


@pytest.mark.slow
@needs_ocp
@pytest.mark.parametrize("name", ["main.step", "main.igs", "main144.iges", "assembly.step", "placed.igs"])
def test_region_area_agrees_with_brepgprop(files, name):
    cad, occ = read(files, name), Occ(files[name])
    worst = 0.0
    for f in cad.faces:
        ours = region_area(f.surface, f.loops_uv)
        theirs = occ_area(occ.originals[f.index])
        assert f.area == pytest.approx(theirs, rel=1e-12)  # both BRepGProp to 1e-10
        worst = max(worst, abs(ours - theirs) / theirs)
    _record("region area relative error", worst)
    assert worst <= 1e-6


@needs_ocp
def test_seam_face_area(files, cf):
    """The face across the periodic surface's knot-range end: its origin moved,
    region area = the area of the two halves (BRepGProp on the face itself
    varies by 3e-6 with its precision there)."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    f = read(files, "seam.stp").faces[0]
    assert f.kind == "bspline" and f.trimmed
    # the file's face runs from -2.5 to 4 (OCCT moved it by a period); the domain holds it
    lo, hi = f.loops_uv[0][:, 0].min(), f.loops_uv[0][:, 0].max()
    assert hi - lo == pytest.approx(6.5) and f.surface.domain[0, 1] - f.surface.domain[0, 0] == pytest.approx(8.0)
    from OCP.BRep import BRep_Tool
    s = cf._static(BRep_Tool, "Surface")(cf.face_periodic_bspline())
    halves = sum(occ_area(BRepBuilderAPI_MakeFace(s, a, b, 0.0, 1.0, 1e-9).Face()) for a, b in ((5.5, 8.0), (0.0, 4.0)))
    rel = abs(region_area(f.surface, f.loops_uv) - halves) / halves
    _record("region area relative error", rel)
    assert rel <= 1e-9


@needs_ocp
def test_loops_sticking_out_are_clipped(files, cf):
    """Outer loops 0.4 % outside the domain: clipped to it. Without holes the
    face is then the whole surface (untrimmed); the areas are those of the
    faces bounded by the domain itself."""
    cad = read(files, "sticking.step")
    assert len(cad.faces) == 2
    want = sorted(occ_area(f) for f in cf.faces_clipped())
    by_area = sorted(cad.faces, key=lambda f: region_area(f.surface, f.loops_uv))
    for f, area in zip(by_area, want):
        d = f.surface.domain
        assert np.allclose(d, [[0, 1], [0, 1]])
        outer = f.loops_uv[0]
        assert outer.min(axis=0) == pytest.approx([0, 0], abs=0) and outer.max(axis=0) == pytest.approx([1, 1], abs=0)
        # OCCT's reader moves trims that leave a B-spline's domain back onto it
        # (by 1.6e-5 of the domain where the loop ran along the domain's edge)
        # and raises the edge tolerances to ~0.3: the areas agree to that
        rel = abs(region_area(f.surface, f.loops_uv) - area) / area
        _record("sticking-out faces: area vs the faces clipped by hand", rel)
        assert rel < 1e-5 and f.tolerance > 0.1
    assert [f.trimmed for f in by_area] == [True, False]  # the holed face has the smaller area


@pytest.mark.slow
@needs_ocp
def test_reversed_face_is_flipped(files):
    """The reversed face is the free-outer face reversed: the same points at u -> a + b - u, the
    opposite normal, the loops mirrored (and still outer counter-clockwise)."""
    f = named(read(files, "main.step"))
    fwd, rev = f["free"], f["reversed"]
    assert rev.reversed and not fwd.reversed
    assert np.allclose(fwd.surface.domain, rev.surface.domain)
    uv = random_uv(fwd, 100)
    (a, b), _ = fwd.surface.domain
    mirrored = np.column_stack([a + b - uv[:, 0], uv[:, 1]])
    e1, e2 = fwd.surface.evaluate(uv), rev.surface.evaluate(mirrored)
    assert np.max(np.abs(e1.xyz - e2.xyz)) < 1e-12
    assert np.max(np.abs(e1.normal + e2.normal)) < 1e-12
    for l1, l2 in zip(fwd.loops_uv, rev.loops_uv):
        m = np.column_stack([a + b - l2[:, 0], l2[:, 1]])
        # the same point set (the walk runs the other way)
        assert np.max(np.min(np.linalg.norm(l1[:, None] - m[None], axis=2), axis=1)) < 1e-12
    assert rev.area == pytest.approx(fwd.area, rel=1e-12)


@needs_ocp
def test_periodic_faces(files):
    f = named(read(files, "main.step"))
    tube, cyl, sphere = f["tube"], f["cylinder"], f["sphere"]
    # the periodic B-spline with 8 poles in u is 11 after SetUNotPeriodic (degree 3)
    assert tube.surface.shape[0] == 11 and not tube.trimmed
    assert cyl.kind == "cylinder" and not cyl.trimmed
    P = cyl.surface.points(random_uv(cyl, 100))
    assert np.max(np.abs(np.hypot(P[:, 0] - 1, P[:, 1] - 2) - 5.0)) < 1e-12  # on the cylinder r=5
    P = sphere.surface.points(random_uv(sphere, 100))
    assert np.max(np.abs(np.linalg.norm(P, axis=1) - 7.0)) < 1e-12


@pytest.mark.slow
@needs_ocp
def test_assembly_places_each_instance(files, cf):
    """Three placements of one face: three faces, each the face moved."""
    from OCP.gp import gp_Pnt
    cad = read(files, "assembly.step")
    assert len(cad.faces) == 3 and [f.index for f in cad.faces] == [0, 1, 2]
    table = face_table(cad)
    assert len({round(e["area"], 9) for e in table}) == 1 and len({tuple(e["bbox"]) for e in table}) == 3
    # the original face's points, moved by each placement, are points of the read faces
    mm = read(files, "mm.step").faces[0]
    uv = random_uv(mm, 30)
    base = mm.surface.points(uv)
    for f, t in zip(cad.faces, cf.placements()):
        moved = np.array([[q.X(), q.Y(), q.Z()] for q in (gp_Pnt(*p).Transformed(t) for p in base)])
        assert np.max(np.abs(f.surface.points(uv) - moved)) < 1e-9


@pytest.mark.slow
@needs_ocp
def test_units_are_the_files(files):
    mm = read(files, "mm.step")
    metre, inch, igs_m = read(files, "metre.step"), read(files, "inch.step"), read(files, "metre.igs")
    assert (mm.units, metre.units, inch.units, igs_m.units) == ("mm", "m", "in", "m")
    assert (metre.mm_per_unit, inch.mm_per_unit, igs_m.mm_per_unit) == (1000.0, 25.4, 1000.0)
    a = mm.faces[0]
    for cad, k in ((metre, 1000.0), (inch, 25.4)):
        f = cad.faces[0]
        assert f.area == pytest.approx(a.area / k**2, rel=1e-9)
        assert np.allclose(f.bbox, np.array(a.bbox) / k, rtol=1e-9, atol=1e-12)
        uv = random_uv(f, 20)
        assert np.allclose(f.surface.points(uv), a.surface.points(uv) / k, rtol=1e-9, atol=1e-12)
        assert region_area(f.surface, f.loops_uv) == pytest.approx(f.area, rel=1e-6)
    main = named(read(files, "main.igs"))["rational"]  # in mm
    assert igs_m.faces[0].area == pytest.approx(main.area / 1e6, rel=1e-9)
    occ = Occ(files["metre.step"], 1000.0)
    f = metre.faces[0]
    uv = random_uv(f)
    assert np.max(np.abs(f.surface.points(uv) - occ.surface_points(0, uv))) < 1e-12


@needs_ocp
def test_info_table(files):
    cad = read(files, "main.step")
    info = json.loads(json.dumps(cad_info(cad)))
    assert info["units"] == "mm" and len(info["faces"]) == len(cad.faces)
    for e, f in zip(info["faces"], cad.faces):
        assert set(e) == {"index", "kind", "area", "trimmed", "bbox"}
        assert (e["index"], e["kind"], e["trimmed"]) == (f.index, f.kind, f.trimmed)
        assert e["area"] == f.area and len(e["bbox"]) == 6
    box = [e for e in info["faces"] if e["kind"] == "plane" and round(e["area"]) in (600, 300, 200)]
    assert len(box) == 6  # the box from (-30, 0, 0), 10 x 20 x 30
    lo = np.min([e["bbox"][:3] for e in box], axis=0)
    hi = np.max([e["bbox"][3:] for e in box], axis=0)
    assert np.allclose(lo, [-30, 0, 0], atol=1e-9) and np.allclose(hi, [-20, 20, 30], atol=1e-9)
    sphere = [e for e in info["faces"] if e["kind"] == "sphere"][0]["bbox"]
    assert np.allclose(sphere, [-7, -7, -7, 7, 7, 7], atol=1e-9)
    torus = [e for e in info["faces"] if e["kind"] == "torus"][0]["bbox"]  # R 8, r 2.5, about y at (0, 30, 0)
    assert np.allclose(torus, [-10.5, 27.5, -10.5, 10.5, 32.5, 10.5], atol=1e-9)
    worst = 0.0
    for f in cad.faces:  # dense points of the region lie in the box and come close to its sides
        from shapely import Polygon, contains_xy
        uv = random_uv(f, 20000)
        poly = Polygon(f.loops_uv[0], f.loops_uv[1:])
        P = f.surface.points(np.vstack([uv[contains_xy(poly, uv[:, 0], uv[:, 1])], *f.loops_uv]))
        lo, hi = np.array(f.bbox[:3]), np.array(f.bbox[3:])
        size = float(np.max(hi - lo))
        assert np.all(P >= lo - 1e-9 * size) and np.all(P <= hi + 1e-9 * size), f.index
        gap = max(np.max(np.min(P, axis=0) - lo), np.max(hi - np.max(P, axis=0))) / size
        worst = max(worst, gap)
    assert worst < 5e-3


@needs_ocp
def test_face_index_out_of_range(files):
    cad = read(files, "assembly.step")
    assert cad.face(2).index == 2
    for bad in (3, -1, 10**6):
        with pytest.raises(SettingsError) as exc:
            cad.face(bad)
        msg = str(exc.value)
        assert "\n" not in msg and f"face index {bad} is out of range" in msg and "0 to 2" in msg
    with pytest.raises(SettingsError):
        cad.face("1")


@pytest.mark.slow
@needs_ocp
def test_small_file_reads_quickly(files):
    t = time.perf_counter()
    read_cad_faces(files["mm.step"])
    elapsed = time.perf_counter() - t
    _record("read seconds (small file, child start included)", elapsed)
    assert elapsed < 8.0  # ~1.5-2.5 s here; the margin is for a loaded machine


# ====================================================================== without Open CASCADE
def _domain_loop(surface) -> np.ndarray:
    (u0, u1), (v0, v1) = surface.domain
    return np.array([[u0, v0], [u1, v0], [u1, v1], [u0, v1]])


@pytest.mark.parametrize("name", ["cone", "octant", "dome", "saddle", "half_cylinder", "garment"])
def test_region_area_of_the_whole_domain(name):
    """The domain as a region: the examples' independent reference areas."""
    from flatweave.reading.examples import example_info, load_example
    surface, info = load_example(name), example_info(name)
    assert region_area(surface, [_domain_loop(surface)]) == pytest.approx(info["reference_area"], rel=1e-10)


def test_region_area_and_box_of_flat_polygons():
    """A flat patch x = 2u, y = 3v: area = 6 x polygon area, holes out."""
    from flatweave.geometry.nurbs import NurbsSurface
    from flatweave.geometry.uvregion import region_bbox
    P = np.array([[[0, 0, 1.0], [0, 3, 1.0]], [[2, 0, 1.0], [2, 3, 1.0]]])
    s = NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], P)
    outer = np.array([[0.1, 0.1], [0.9, 0.1], [0.9, 0.8], [0.1, 0.8]])
    hole = np.array([[0.3, 0.3], [0.3, 0.5], [0.5, 0.5], [0.5, 0.3]])  # clockwise
    tri = np.array([[0.6, 0.2], [0.7, 0.6], [0.8, 0.2]])[::-1]
    want = 6.0 * (0.8 * 0.7 - 0.04 - 0.5 * 0.2 * 0.4)
    assert region_area(s, [outer, hole, tri]) == pytest.approx(want, rel=1e-13)
    assert region_area(s, [outer[::-1], hole[::-1], tri]) == pytest.approx(want, rel=1e-13)  # any sense
    assert np.allclose(region_bbox(s, [outer, hole]), [0.2, 0.3, 1.0, 1.8, 2.4, 1.0], atol=1e-13)


def test_region_box_of_the_octant():
    from flatweave.reading.examples import load_example
    from flatweave.geometry.uvregion import region_bbox
    s = load_example("octant")
    assert np.allclose(region_bbox(s, [_domain_loop(s)]), [0, 0, 0, 1, 1, 1], atol=1e-12)


def test_loop_helpers():
    """Reversal keeps point 0 and maps the corners; cleaning clips to the
    domain and drops repeats; flip_u mirrors knots, rows and loops."""
    from flatweave.reading.cad import _clean_loop, _reverse_loop, flip_u
    p = np.array([[0, 0], [1, 0], [2, 0], [2, 1], [1, 1], [0, 1.0]])
    q, b = _reverse_loop(p, np.array([0, 2, 3, 5]))
    assert np.array_equal(q, p[[0, 5, 4, 3, 2, 1]]) and list(b) == [0, 1, 3, 4]
    assert all(np.array_equal(q[i], p[j]) for i, j in zip(b, [0, 5, 3, 2]))  # corners stay corners
    dom = np.array([[0.0, 2.0], [0.0, 1.0]])
    r, b = _clean_loop(np.array([[-0.01, 0], [0, 0], [2.003, -0.002], [2, 1], [0, 1], [-0.01, 0]]),
                       np.array([0, 2, 3]), dom)
    assert np.array_equal(r, [[0, 0], [2, 0], [2, 1], [0, 1]]) and list(b) == [0, 1, 2]
    knots = np.array([0, 0, 0, 0.3, 1, 1, 1.0])
    ctrl = np.arange(4 * 2 * 3, dtype=float).reshape(4, 2, 3)
    k2, c2, w2, (l2,) = flip_u(2, knots, ctrl, np.ones((4, 2)), [np.array([[0.25, 0.5]])])
    assert np.allclose(k2, [0, 0, 0, 0.7, 1, 1, 1]) and np.array_equal(c2, ctrl[::-1])
    assert np.allclose(l2, [[0.75, 0.5]])


# ====================================================================== bad input
def one_line_error(exc_info, *words):
    msg = str(exc_info.value)
    assert isinstance(exc_info.value, FlatweaveError)
    assert "\n" not in msg and msg.strip() == msg and len(msg) < 400, msg
    for w in words:
        assert w in msg, msg
    return msg


@pytest.mark.parametrize("name, words", [
    ("empty.step", ["empty.step", "empty"]),
    ("binary_garbage.step", ["binary_garbage.step", "not a STEP file"]),
    ("truncated.step", ["truncated.step", "truncated"]),
    ("not_step.stp", ["not_step.stp", "not a STEP file"]),
    ("not_iges.igs", ["not_iges.igs", "not an IGES file"]),
])
def test_bad_files_without_starting_occ(name, words):
    """Checked before any child starts, so also without Open CASCADE."""
    with pytest.raises(CadFileError) as exc:
        read_cad_faces(BAD / name)
    one_line_error(exc, *words)


def test_bad_names(tmp_path):
    with pytest.raises(CadFileError) as exc:
        read_cad_faces(tmp_path / "missing.step")
    one_line_error(exc, "missing.step", "no such file")
    (tmp_path / "part.obj").write_text("v 0 0 0\n")
    with pytest.raises(CadFileError) as exc:
        read_cad_faces(tmp_path / "part.obj")
    one_line_error(exc, "part.obj", "not a STEP")
    folder = tmp_path / "dir.step"
    folder.mkdir()
    with pytest.raises(CadFileError) as exc:
        read_cad_faces(folder)
    one_line_error(exc, "dir.step")


@pytest.mark.slow
@needs_ocp
def test_bad_files_read_by_occ(files):
    with pytest.raises(CadFileError) as exc:
        read_cad_faces(BAD / "garbage_body.step")
    one_line_error(exc, "garbage_body.step")
    with pytest.raises(CadFileError) as exc:
        read_cad_faces(files["curve.igs"])
    one_line_error(exc, "curve.igs", "no faces")
    with pytest.raises(CadFileError) as exc:
        read_cad_faces(BAD / "curve_only.igs")
    one_line_error(exc, "curve_only.igs", "no faces")


def test_child_crash_is_one_line(monkeypatch):
    monkeypatch.setenv("FLATWEAVE_CAD_FAULT", "abort")
    with pytest.raises(CadFileError) as exc:
        read_cad_faces(BAD / "tiny.step")
    one_line_error(exc, "tiny.step", "crashed", "SIGABRT")


@pytest.mark.slow
def test_child_hang_is_stopped(monkeypatch):
    monkeypatch.setenv("FLATWEAVE_CAD_FAULT", "hang")
    t = time.perf_counter()
    with pytest.raises(CadFileError) as exc:
        read_cad_faces(BAD / "tiny.step", timeout=1.5)
    assert time.perf_counter() - t < 15
    one_line_error(exc, "tiny.step", "longer than 1.5 s")
    monkeypatch.setenv("FLATWEAVE_CAD_TIMEOUT", "soon")
    with pytest.raises(SettingsError):
        read_cad_faces(BAD / "tiny.step")


def test_missing_open_cascade(monkeypatch):
    """The child behaves as if OCP were not installed: a one-line error
    naming the package and how to install it."""
    monkeypatch.setenv("FLATWEAVE_CAD_FAULT", "no-ocp")
    for name in ("tiny.step", "curve_only.igs"):
        with pytest.raises(CadUnavailableError) as exc:
            read_cad_faces(BAD / name)
        msg = one_line_error(exc, name, "needs Open CASCADE", "pip install cadquery-ocp-novtk", "flatweave[cad]")
        assert INSTALL_HINT in msg


def test_core_imports_without_open_cascade():
    """import core, flatweave.reading.cad and flatweave.geometry.uvregion with OCP unimportable."""
    code = ("import sys; sys.modules['OCP'] = None\n"
            "import core, flatweave.reading.cad, flatweave.geometry.uvregion, flatweave.geometry.surface_json\n"
            "assert sys.modules['OCP'] is None\n"
            "print('ok')\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr


def test_measured_summary(capsys):
    """Print what the tests above measured (visible with -s)."""
    if MEASURED:
        with capsys.disabled():
            print("\nCAD agreement: " + "; ".join(f"{k} {v:.3g}" for k, v in sorted(MEASURED.items())))
