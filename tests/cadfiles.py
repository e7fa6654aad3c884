"""Test CAD files made with Open CASCADE itself (used by tests/test_cad.py).

Every builder returns a TopoDS shape whose geometry is known: B-spline faces
trimmed by circles and free curves, a rational face with a hole, a reversed
face, periodic faces (a periodic B-spline, a cylinder), analytic solids and a
compound that places one face several times. :func:`write_step` and
:func:`write_iges` write them in a chosen unit and STEP schema.

Only imported by tests that have Open CASCADE (``OCP``); the names of OCP's
array classes moved between 7.x and 8.x, so they are looked up by
:func:`_cls`.
"""

from __future__ import annotations

import math

import numpy as np
from OCP.BRep import BRep_Builder
from OCP.BRepBuilderAPI import (BRepBuilderAPI_MakeEdge, BRepBuilderAPI_MakeFace,
                                BRepBuilderAPI_MakeWire)
from OCP.BRepCheck import BRepCheck_Analyzer
from OCP.BRepLib import BRepLib
from OCP.BRepPrimAPI import (BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCone, BRepPrimAPI_MakeCylinder,
                             BRepPrimAPI_MakeSphere, BRepPrimAPI_MakeTorus)
from OCP.Geom import Geom_BSplineSurface
from OCP.Geom2d import Geom2d_Circle, Geom2d_Line
from OCP.Geom2dAPI import Geom2dAPI_Interpolate
from OCP.GeomAbs import GeomAbs_C1
from OCP.gp import gp_Ax1, gp_Ax2, gp_Ax2d, gp_Circ2d, gp_Dir, gp_Dir2d, gp_Pnt, gp_Pnt2d, gp_Trsf, gp_Vec
from OCP.IGESControl import IGESControl_Writer
from OCP.Interface import Interface_Static
from OCP.ShapeFix import ShapeFix_Face
from OCP.STEPControl import STEPControl_AsIs, STEPControl_Controller, STEPControl_Writer
from OCP.TopLoc import TopLoc_Location
from OCP.TopoDS import TopoDS_Compound


def _cls(*names):
    """The first of ``module.Class`` names that this OCP has (8.x names first)."""
    import importlib
    for name in names:
        mod, _, attr = name.rpartition(".")
        try:
            return getattr(importlib.import_module(mod), attr)
        except (ImportError, AttributeError):
            continue
    raise ImportError(f"none of {names} in this OCP")


def _static(cls, name):
    return getattr(cls, name + "_s", None) or getattr(cls, name)


def _quiet():
    """OCCT's writers print statistics through its default messenger: off."""
    from OCP.Message import Message
    messenger = _static(Message, "DefaultMessenger")()
    printers = messenger.Printers()
    for i in range(printers.Length(), 0, -1):
        messenger.RemovePrinter(printers.Value(i))


_quiet()


Array1_double = _cls("OCP.collections.Array1_double", "OCP.TColStd.TColStd_Array1OfReal")
Array1_int = _cls("OCP.collections.Array1_int", "OCP.TColStd.TColStd_Array1OfInteger")
Array2_double = _cls("OCP.collections.Array2_double", "OCP.TColStd.TColStd_Array2OfReal")
Array2_pnt = _cls("OCP.collections.Array2_gp_Pnt", "OCP.TColgp.TColgp_Array2OfPnt")
HArray1_pnt2d = _cls("OCP.collections.HArray1_gp_Pnt2d", "OCP.TColgp.TColgp_HArray1OfPnt2d")


def _a1(values, cls=Array1_double):
    a = cls(1, len(values))
    for i, x in enumerate(values):
        a.SetValue(i + 1, x)
    return a


def bspline_surface(poles, weights=None, knots_u=None, knots_v=None, degree_u=3, degree_v=3,
                    periodic_u=False):
    """A Geom_BSplineSurface from an (nu, nv, 3) pole net, distinct knots and
    multiplicities ((values, mults) pairs; clamped uniform when omitted)."""
    P = np.asarray(poles, float)
    nu, nv = P.shape[:2]

    def clamped(n, p):
        inner = n - p - 1
        values = list(np.linspace(0.0, 1.0, inner + 2))
        return values, [p + 1] + [1] * inner + [p + 1]

    ku = knots_u or clamped(nu, degree_u)
    kv = knots_v or clamped(nv, degree_v)
    poles_a = Array2_pnt(1, nu, 1, nv)
    for i in range(nu):
        for j in range(nv):
            poles_a.SetValue(i + 1, j + 1, gp_Pnt(*P[i, j]))
    args = [poles_a]
    if weights is not None:
        W = np.asarray(weights, float)
        wa = Array2_double(1, nu, 1, nv)
        for i in range(nu):
            for j in range(nv):
                wa.SetValue(i + 1, j + 1, float(W[i, j]))
        args.append(wa)
    args += [_a1(ku[0]), _a1(kv[0]), _a1(ku[1], Array1_int), _a1(kv[1], Array1_int),
             degree_u, degree_v, periodic_u, False]
    return Geom_BSplineSurface(*args)


def wavy_net(nu=6, nv=5, size=(40.0, 30.0), amp=4.0, seed=1):
    """An (nu, nv, 3) pole net over a size[0] x size[1] rectangle, z wavy."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.linspace(0, size[0], nu), np.linspace(0, size[1], nv), indexing="ij")
    z = amp * np.sin(x / size[0] * 3.0) * np.cos(y / size[1] * 2.0) + rng.uniform(-1, 1, x.shape)
    x = x + rng.uniform(-1, 1, x.shape)
    return np.stack([x, y, z], axis=2)


# ---------------------------------------------------------------------- pcurves and faces
def circle2d(cx, cy, r, clockwise=False):
    return Geom2d_Circle(gp_Circ2d(gp_Ax2d(gp_Pnt2d(cx, cy), gp_Dir2d(1, 0)), r, not clockwise))


def free_curve2d(points, periodic=True):
    """A (periodic) interpolating 2D B-spline through points."""
    h = HArray1_pnt2d(1, len(points))
    for i, (x, y) in enumerate(points):
        h.SetValue(i + 1, gp_Pnt2d(float(x), float(y)))
    it = Geom2dAPI_Interpolate(h, periodic, 1e-9)
    it.Perform()
    return it.Curve()


def segment2d(a, b):
    """(line, 0, length): the segment from a to b, as _wire takes it."""
    d = np.subtract(b, a)
    length = float(np.hypot(*d))
    return Geom2d_Line(gp_Pnt2d(*map(float, a)), gp_Dir2d(*(d / length))), 0.0, length


def _wire(surface, curves):
    """A wire on surface from a closed chain of 2D curves (each (curve, t0, t1) or a curve)."""
    mk = BRepBuilderAPI_MakeWire()
    for c in curves:
        if isinstance(c, tuple):
            e = BRepBuilderAPI_MakeEdge(c[0], surface, c[1], c[2]).Edge()
        else:
            e = BRepBuilderAPI_MakeEdge(c, surface).Edge()
        mk.Add(e)
    assert mk.IsDone()
    return mk.Wire()


def trimmed_face(surface, outer=None, holes=()):
    """A face on surface: outer loop (a list of 2D curves; None: the natural
    bounds) and holes (each a list of 2D curves), fixed and with 3D curves."""
    if outer is None:
        mk = BRepBuilderAPI_MakeFace(surface, 1e-9)
        face = mk.Face()
        mk = BRepBuilderAPI_MakeFace(face)
    else:
        mk = BRepBuilderAPI_MakeFace(surface, _wire(surface, outer), True)
    for h in holes:
        mk.Add(_wire(surface, h))
    assert mk.IsDone()
    face = mk.Face()
    # 3D curves close to the pcurves, so that the edge tolerances are small and true
    assert _static(BRepLib, "BuildCurves3d")(face, 1e-9, GeomAbs_C1, 14, 200)
    fix = ShapeFix_Face(face)
    fix.Perform()
    face = fix.Face()
    assert BRepCheck_Analyzer(face).IsValid()
    return face


def face_circle_hole():
    """B-spline face, natural outer bounds, one circular hole: trimmed."""
    s = bspline_surface(wavy_net())
    return trimmed_face(s, None, [[circle2d(0.45, 0.5, 0.2, clockwise=True)]])


def face_free_outer():
    """B-spline face bounded by a free (periodic B-spline) curve, with a
    free-curve hole and a circular hole."""
    s = bspline_surface(wavy_net(7, 6, seed=2))
    t = np.linspace(0, 2 * np.pi, 11)[:-1]
    outer = np.column_stack([0.5 + 0.42 * np.cos(t) * (1 + 0.1 * np.sin(3 * t)),
                             0.5 + 0.4 * np.sin(t) * (1 + 0.1 * np.cos(2 * t))])
    hole = np.column_stack([0.35 + 0.08 * np.cos(-t) * (1 + 0.2 * np.sin(2 * t)), 0.45 + 0.1 * np.sin(-t)])
    return trimmed_face(s, [free_curve2d(outer)], [[free_curve2d(hole)],
                                                     [circle2d(0.66, 0.55, 0.09, clockwise=True)]])


def face_mixed_outer():
    """B-spline face whose outer loop has corners: two segments, a circular
    arc and an open free curve."""
    s = bspline_surface(wavy_net(5, 6, seed=3), degree_u=2)
    arc = circle2d(0.5, 0.1, 0.4)  # from (0.9, 0.1) to (0.1, 0.1) over the top
    free = free_curve2d([(0.1, 0.1), (0.3, 0.02), (0.5, 0.08), (0.7, 0.03), (0.9, 0.1)], periodic=False)
    # counter-clockwise: the free curve along the bottom, then the arc back
    return trimmed_face(s, [free, (arc, 0.0, math.pi)])


STRAIGHT_OUTER = [(0.12, 0.1), (0.9, 0.18), (0.82, 0.92), (0.15, 0.8)]
STRAIGHT_HOLE = [(0.4, 0.35), (0.45, 0.6), (0.62, 0.45)]
"""The loops of face_straight_trims() in (u, v): a quadrilateral (counter-clockwise) and a
triangular hole (clockwise)."""


def face_straight_trims():
    """B-spline face (40 x 30, waves of 8) trimmed by STRAIGHT_OUTER with the hole
    STRAIGHT_HOLE: every edge a line in (u, v) and a curve in space."""
    s = bspline_surface(wavy_net(amp=8.0))

    def polygon(corners):
        return [segment2d(corners[i], corners[(i + 1) % len(corners)]) for i in range(len(corners))]

    return trimmed_face(s, polygon(STRAIGHT_OUTER), [polygon(STRAIGHT_HOLE)])


def sticking_out_surface():
    return bspline_surface(wavy_net(seed=5))


STICKING_OUT = [(-0.004, -0.002), (1.003, -0.002), (1.003, 1.0), (-0.004, 1.0)]
"""The outer loop of the sticking-out faces: the domain [0, 1]^2 grown by up
to 0.4 % (the surface is extrapolated there)."""


def _rectangle(corners):
    return [segment2d(corners[i], corners[(i + 1) % 4]) for i in range(4)]


def faces_sticking_out():
    """Two faces whose outer loop sticks out of the surface's domain by a
    fraction of a percent: one without holes (clipped, it is the domain
    rectangle: untrimmed) and one with a circular hole."""
    s = sticking_out_surface()
    return [trimmed_face(s, _rectangle(STICKING_OUT)),
            trimmed_face(s, _rectangle(STICKING_OUT), [[circle2d(0.5, 0.5, 0.2, clockwise=True)]])]


def faces_clipped():
    """The faces of faces_sticking_out() with the outer loop on the domain."""
    s = sticking_out_surface()
    domain = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
    return [trimmed_face(s, _rectangle(domain)),
            trimmed_face(s, _rectangle(domain), [[circle2d(0.5, 0.5, 0.2, clockwise=True)]])]


def face_rational_hole():
    """A rational B-spline face (a bent patch with weights != 1) with a hole."""
    nu, nv = 3, 5
    r = 20.0
    poles = np.zeros((nu, nv, 3))
    weights = np.ones((nu, nv))
    for j, y in enumerate(np.linspace(0, 30, nv)):
        poles[0, j] = (r, y, 0)
        poles[1, j] = (r, y, r)
        poles[2, j] = (0, y, r)
        weights[1, j] = math.cos(math.pi / 4) * (1.0 + 0.1 * j)
    poles[:, 2, 0] += 2.0
    s = bspline_surface(poles, weights, degree_u=2, degree_v=3,
                        knots_u=([0.0, 1.0], [3, 3]), knots_v=([0.0, 0.5, 1.0], [4, 1, 4]))
    return trimmed_face(s, None, [[circle2d(0.5, 0.4, 0.15, clockwise=True)]])


def face_reversed():
    """The free-outer face with its orientation reversed (normal = -Su x Sv)."""
    return face_free_outer().Reversed()


def face_periodic_bspline():
    """A face on a u-periodic B-spline surface (a wobbly tube), natural bounds."""
    n = 8
    poles = np.zeros((n, 4, 3))
    for i in range(n):
        a = 2 * math.pi * i / n
        for j, z in enumerate(np.linspace(0, 20, 4)):
            rr = 10.0 + (1.5 if i % 2 else 0.0) + 0.5 * j
            poles[i, j] = (rr * math.cos(a), rr * math.sin(a), z)
    s = bspline_surface(poles, knots_u=(list(np.arange(n + 1.0)), [1] * (n + 1)),
                        degree_u=3, degree_v=3, periodic_u=True)
    mk = BRepBuilderAPI_MakeFace(s, 1e-9)
    return mk.Face()


def cylinder_solid():
    """A cylinder (radius 5, height 12): two planes and a periodic cylinder face."""
    return BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(1, 2, 3), gp_Dir(0, 0, 1)), 5.0, 12.0).Shape()


def analytic_solids():
    """A compound of a box, a sphere, a cone and a torus (planes, poles, apex)."""
    b = BRep_Builder()
    c = TopoDS_Compound()
    b.MakeCompound(c)
    b.Add(c, BRepPrimAPI_MakeBox(gp_Pnt(-30, 0, 0), 10, 20, 30).Shape())
    b.Add(c, BRepPrimAPI_MakeSphere(gp_Pnt(0, 0, 0), 7.0).Shape())
    b.Add(c, BRepPrimAPI_MakeCone(gp_Ax2(gp_Pnt(20, 0, 0), gp_Dir(0, 0, 1)), 6.0, 0.0, 9.0).Shape())
    b.Add(c, BRepPrimAPI_MakeTorus(gp_Ax2(gp_Pnt(0, 30, 0), gp_Dir(0, 1, 0)), 8.0, 2.5).Shape())
    return c


def placements():
    """Three rigid motions (the identity is not one of them)."""
    out = []
    for k, (axis, ang, move) in enumerate([((0, 0, 1), 0.7, (100, 0, 0)),
                                           ((1, 0, 0), 1.9, (0, 80, 10)),
                                           ((1, 1, 1), -2.4, (-50, -20, 30))]):
        t = gp_Trsf()
        t.SetRotation(gp_Ax1(gp_Pnt(0, 0, 0), gp_Dir(*axis)), ang)
        t2 = gp_Trsf()
        t2.SetTranslation(gp_Vec(*move))
        out.append(t2.Multiplied(t))
    return out


def placed_compound(face=None):
    """A compound placing one face (shared geometry) three times by locations."""
    face = face if face is not None else face_circle_hole()
    b = BRep_Builder()
    c = TopoDS_Compound()
    b.MakeCompound(c)
    for t in placements():
        b.Add(c, face.Moved(TopLoc_Location(t)))
    return c


def compound(*shapes):
    b = BRep_Builder()
    c = TopoDS_Compound()
    b.MakeCompound(c)
    for s in shapes:
        b.Add(c, s)
    return c


# ---------------------------------------------------------------------- writing
def write_step(shape, path, unit="MM", schema="AP214IS", assembly=False):
    """Write shape to a STEP file in the given unit (MM, M, CM, INCH, ...) and schema."""
    _static(STEPControl_Controller, "Init")()
    set_c = _static(Interface_Static, "SetCVal")
    set_i = _static(Interface_Static, "SetIVal")
    assert set_c("write.step.schema", schema), schema
    assert set_c("write.step.unit", unit), unit
    assert set_i("write.step.assembly", 1 if assembly else 0)
    w = STEPControl_Writer()
    w.Transfer(shape, STEPControl_AsIs)
    assert int(w.Write(str(path))) == 1, path  # IFSelect_RetDone
    return path


def write_iges(shape, path, unit="MM", brep=True):
    """Write shape to an IGES file: brep=True as BRep solids/faces (type 186/510),
    False as trimmed surfaces (type 144)."""
    w = IGESControl_Writer(unit, 1 if brep else 0)
    assert w.AddShape(shape)
    w.ComputeModel()
    assert w.Write(str(path)), path
    return path


def write_iges_curve_only(path):
    """An IGES file holding only a 3D curve (no surface at all)."""
    from OCP.GC import GC_MakeCircle
    circ = GC_MakeCircle(gp_Ax2(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), 5.0).Value()
    edge = BRepBuilderAPI_MakeEdge(circ).Edge()
    return write_iges(edge, path)
