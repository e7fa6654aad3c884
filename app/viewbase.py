"""What the 3D view and the pattern view share: the render widget, colour
scales as VTK sees them, the spring mesh layer and hover picking.

With :mod:`flatweave.app.view3d`, :mod:`flatweave.app.view2d` and :mod:`flatweave.app.canvas` (which
makes the render widget) this is the only code that touches pyvista or VTK;
the rest of the app hands these classes numpy arrays (:class:`flatweave.app.frames.Frame`)
and :class:`ViewOptions`.

Live updates write into the existing ``pv.PolyData`` objects (points, cell
scalars) so no actor is rebuilt per frame; only a change of topology (nodes
deleted or added) replaces a layer's geometry, still in the same actors.
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np
import pyvista as pv
from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray
from vtkmodules.vtkCommonCore import vtkPoints
from vtkmodules.vtkCommonDataModel import vtkCellArray
import vtkmodules.vtkRenderingFreeType  # noqa: F401  (the text renderer text_size measures with)
from vtkmodules.vtkRenderingCore import vtkCellPicker, vtkColorTransferFunction, vtkTextRenderer

from flatweave.app.canvas import make_plotter
from flatweave.app.colours import YELLOW, ramp, shear_stops, strain_range, strain_stops

__all__ = ["ViewOptions", "ColourScale", "MeshLayer", "ViewBase", "KINDS", "scale_stops", "group_stops", "cell_springs",
           "THREAD", "DIAGONAL", "SCALE_TITLES", "text_size"]

# Layers start empty and are filled in place (an actor per layer for the app's lifetime).
pv.global_theme.allow_empty_mesh = True

KINDS = ("weft", "warp", "diag")
BACKGROUND = "#e9edf1"
HOVER_INTERVAL = 0.04  # seconds between two hover picks at most
THIN_LINES_ABOVE = 4000  # springs; denser meshes are drawn with 1-pixel lines
DENSE_PIXELS = 7.0  # threads closer than this on screen: draw coloured cells, not a moire of lines


@dataclass(frozen=True)
class ViewOptions:
    """How the views draw a frame (view state, not part of the document).

    mode : "strain" (springs coloured by strain), "shear" (cells by shear angle)
        or "fibre" (cells by the weft's deviation from the rosette, :mod:`flatweave.method.fibres`)
    weft, warp, diag : which spring kinds are drawn (strain mode)
    surface : draw the surface under the mesh (3D view)
    nodes : draw boundary nodes (yellow) and dart nodes (red +, blue -)
    shear_warning_deg, shear_limit_deg : the shear scale's thresholds
    units : model units, for the pattern's scale bar
    fit_deviation : colour the mesh a surface was fitted to by its vertices' distance to it (3D view)
    fit_mesh : draw that mesh beside the surface (3D view; off: over it, when its deviation is shown)
    """

    mode: str = "strain"
    weft: bool = True
    warp: bool = True
    diag: bool = True
    surface: bool = True
    nodes: bool = True
    shear_warning_deg: float = 15.0
    shear_limit_deg: float = 30.0
    units: str = "m"
    fit_deviation: bool = False
    fit_mesh: bool = False

    @property
    def kinds(self) -> tuple[bool, bool, bool]:
        return (self.weft, self.warp, self.diag)


THREAD, DIAGONAL = "thread", "diagonal"
SCALE_TITLES = {THREAD: "thread\nstrain (%)", DIAGONAL: "diagonal\nstrain (%)", "shear": "shear (deg)",
                "fibre": "fibre angle\n(deg)"}
CELL_MODES = ("shear", "fibre")  # the modes that colour the cells, not the springs


def fibre_stops(frame) -> list:
    """The fibre-angle scale: symmetric about 0 over the frame's deviations
    (blue turned one way, green along the rosette, red the other)."""
    dev = np.asarray(getattr(frame, "fibre", ()), dtype=float)
    dev = np.abs(dev[np.isfinite(dev)])
    top = max(float(dev.max()) if dev.size else 0.0, 1e-12)
    return strain_stops(-top, top)


def cell_values(frame, mode: str) -> np.ndarray:
    """What the cells show in a cell mode: |shear|, or the signed fibre deviation."""
    if mode == "fibre":
        fibre = np.asarray(frame.fibre, dtype=float)
        return fibre if len(fibre) == len(frame.shear) else np.full(len(frame.shear), np.nan)
    return np.abs(frame.shear)
KIND_GROUP = (THREAD, THREAD, DIAGONAL)  # each spring kind's colour scale


def group_stops(frame, options: ViewOptions, group: str) -> list:
    """The colour stops of one strain scale (``THREAD``: weft and warp springs,
    ``DIAGONAL``: diagonal ones) in percent, over the springs of that group's
    shown kinds (all of the group when none is shown): blue at its most
    compressive, green at 0, red at its most tensile.

    Each group has its own scale: on woven cloth the diagonals (shear proxies)
    stretch a hundred times more than the threads, and one scale over both
    painted every thread the same green (docs/decisions/0021-strain-scales-dense-cells-home-view.md)."""
    kinds = [k for k, g in enumerate(KIND_GROUP) if g == group]
    kind = frame.mesh.kind
    strain = 100.0 * np.asarray(frame.strain)
    shown = [k for k in kinds if options.kinds[k]] or kinds
    sel = np.isin(kind, shown) if len(strain) else np.zeros(0, bool)
    return strain_stops(*strain_range(strain[sel]))


def scale_stops(frame, options: ViewOptions) -> list:
    """The colour stops of the scale a view's first colour bar shows: shear in
    degrees (shear mode), else the thread scale (or the diagonal one when no
    thread kind is shown)."""
    if options.mode == "shear":
        return shear_stops(options.shear_warning_deg, options.shear_limit_deg)
    if options.mode == "fibre":
        return fibre_stops(frame)
    return group_stops(frame, options, THREAD if (options.weft or options.warp) else DIAGONAL)


class ColourScale:
    """A VTK colour transfer function that is exactly :func:`flatweave.app.colours.ramp`
    on the given stops (piecewise linear in RGB, clamped at the ends)."""

    def __init__(self):
        self.ctf = vtkColorTransferFunction()
        self.ctf.SetColorSpaceToRGB()
        self.ctf.ClampingOn()
        self.stops: list = []

    def set_stops(self, stops) -> None:
        if stops == self.stops:
            return
        self.stops = list(stops)
        self.ctf.RemoveAllPoints()
        for value, (r, g, b) in self.stops:
            self.ctf.AddRGBPoint(float(value), r, g, b)

    @property
    def range(self) -> tuple[float, float]:
        return (self.stops[0][0], self.stops[-1][0]) if self.stops else (0.0, 1.0)

    def map(self, values: np.ndarray) -> np.ndarray:
        """(k, 3) uint8: the colours VTK gives ``values`` (what is on screen)."""
        arr = numpy_to_vtk(np.ascontiguousarray(values, dtype=float), deep=True)
        out = self.ctf.MapScalars(arr, 0, -1)  # VTK_COLOR_MODE_DEFAULT, magnitude
        rgba = np.frombuffer(memoryview(out), dtype=np.uint8).reshape(-1, out.GetNumberOfComponents())
        return rgba[:, :3].copy()

    def expected(self, values: np.ndarray) -> np.ndarray:
        """(k, 3) float: the same colours by numpy (:func:`flatweave.app.colours.ramp`)."""
        return ramp(values, self.stops)


def text_size(prop, text: str, dpi: int = 72) -> tuple[int, int]:
    """(width, height) in pixels of ``text`` drawn with the text property ``prop``."""
    box = [0, 0, 0, 0]
    if not vtkTextRenderer.GetInstance().GetBoundingBox(prop, text, box, int(dpi)):
        return 0, 0
    return box[1] - box[0] + 1, box[3] - box[2] + 1


def _line_cells(ends: np.ndarray) -> np.ndarray:
    """VTK line cell array of segments ``ends`` (k, 2)."""
    ends = np.asarray(ends, dtype=np.int64).reshape(-1, 2)
    return np.column_stack([np.full(len(ends), 2, dtype=np.int64), ends]).ravel()


def polyline_cells(loops, closed: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Points and VTK line cells of polylines (each (k, d) with d = 2 or 3)."""
    pts, cells, base = [], [], 0
    for loop in loops:
        loop = np.asarray(loop, dtype=float)
        if len(loop) < 2:
            continue
        if loop.shape[1] == 2:
            loop = np.column_stack([loop, np.zeros(len(loop))])
        k = len(loop)
        ids = base + np.arange(k)
        if closed:
            ids = np.append(ids, base)
        cells.append(np.concatenate([[len(ids)], ids]))
        pts.append(loop)
        base += k
    if not pts:
        return np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
    return np.vstack(pts), np.concatenate(cells).astype(np.int64)


def replace_geometry(poly: pv.PolyData, points: np.ndarray, lines=None, faces=None, verts: bool = False,
                     scalars: np.ndarray | None = None) -> None:
    """Give an existing PolyData (and so its actor) new geometry in one go:
    ``lines`` or ``faces`` (VTK legacy cell arrays), or one vertex per point
    (``verts``); ``scalars`` become the cell array "value".

    Built with plain VTK calls: pyvista's constructors cost most of a live
    frame's Python time when nodes come and go (docs/decisions/0009-window-on-software-opengl.md)."""
    points = np.ascontiguousarray(points, dtype=float).reshape(-1, 3)
    has_lines = lines is not None and len(lines) > 0
    has_faces = faces is not None and len(faces) > 0
    poly.Initialize()
    # Points even when emptied: with none, VTK keeps the polydata's cell bounds from before (they are
    # recomputed only when the points or cells are newer), its actor reports them, and the camera's
    # clipping range stretches to geometry no longer drawn, clipping a much smaller piece.
    vtk_points = vtkPoints()
    poly.SetPoints(vtk_points)
    if len(points) and (verts or has_lines or has_faces):
        vtk_points.SetData(numpy_to_vtk(points, deep=True))
        if verts:
            legacy = np.column_stack([np.ones(len(points), dtype=np.int64), np.arange(len(points))]).ravel()
        else:
            legacy = lines if has_lines else faces
        cells = vtkCellArray()
        cells.ImportLegacyFormat(numpy_to_vtkIdTypeArray(np.ascontiguousarray(legacy, dtype=np.int64), deep=True))
        (poly.SetVerts if verts else poly.SetLines if has_lines else poly.SetPolys)(cells)
        if scalars is not None and cells.GetNumberOfCells() == len(scalars):
            values = numpy_to_vtk(np.ascontiguousarray(scalars, dtype=float), deep=True)
            values.SetName("value")
            poly.GetCellData().AddArray(values)
    poly.Modified()


def cell_springs(mesh) -> np.ndarray:
    """(c, 6) int: the springs along each cell's sides and diagonals, -1 where
    there is none (cut by a dart): columns weft (0-1), warp (1-2), weft (3-2),
    warp (0-3), diagonal (0-2), diagonal (1-3), by the cells' corner order."""
    cells = np.asarray(mesh.cells, dtype=np.int64).reshape(-1, 4)
    if not len(cells) or not mesh.n_springs:
        return np.full((len(cells), 6), -1, dtype=np.int64)
    n = np.int64(mesh.n_nodes)
    e = np.sort(np.asarray(mesh.ends, dtype=np.int64), axis=1)
    keys = e[:, 0] * n + e[:, 1]
    order = np.argsort(keys)
    sorted_keys = keys[order]
    out = np.empty((len(cells), 6), dtype=np.int64)
    for col, (s, t) in enumerate(((0, 1), (1, 2), (3, 2), (0, 3), (0, 2), (1, 3))):
        want = np.minimum(cells[:, s], cells[:, t]) * n + np.maximum(cells[:, s], cells[:, t])
        pos = np.minimum(np.searchsorted(sorted_keys, want), len(keys) - 1)
        out[:, col] = np.where(sorted_keys[pos] == want, order[pos], -1)
    return out


def cell_strain(strain_pct: np.ndarray, springs: np.ndarray, use: np.ndarray) -> np.ndarray:
    """(c,) the signed strain of largest size among each cell's springs
    ``springs`` (c, 6) in the columns ``use`` (bool (6,)); 0 for a cell with none."""
    sel = springs[:, use]
    if not sel.size:
        return np.zeros(len(springs))
    vals = np.where(sel >= 0, np.asarray(strain_pct)[np.maximum(sel, 0)], 0.0)
    pick = np.argmax(np.abs(vals), axis=1)
    return np.take_along_axis(vals, pick[:, None], axis=1)[:, 0]


_CELL_COLUMNS = {0: np.array([True, False, True, False, False, False]),   # weft sides
                 1: np.array([False, True, False, True, False, False]),   # warp sides
                 2: np.array([False, False, False, False, True, True])}   # diagonals


class MeshLayer:
    """The spring mesh drawn in one view: a line actor per spring kind (threads
    and diagonals on colour scales of their own), the cells coloured by shear
    (shear mode) or, when the springs are too dense to draw as lines, by strain,
    and boundary and dart node spheres.

    ``z`` lifts (or sinks) the layer along z, for the flat pattern's stacking.
    """

    def __init__(self, plotter, line_width: float = 2.0, point_size: float = 9.0):
        self.plotter = plotter
        self.line_width = line_width
        self.thread_scale = ColourScale()
        self.diag_scale = ColourScale()
        self.shear_scale = ColourScale()
        self.fibre_scale = ColourScale()
        self.springs = [pv.PolyData() for _ in KINDS]
        self.spring_index = [np.zeros(0, dtype=np.int64) for _ in KINDS]
        self.cells = pv.PolyData()
        self.cell_index = np.zeros((0, 6), dtype=np.int64)
        self.boundary = pv.PolyData()
        self.dart_pos = pv.PolyData()
        self.dart_neg = pv.PolyData()
        scales = (self.thread_scale, self.thread_scale, self.diag_scale)
        self.spring_actors = [self._scalar_actor(p, scale, line_width=line_width)
                              for p, scale in zip(self.springs, scales)]
        self.cell_actor = self._scalar_actor(self.cells, self.shear_scale, line_width=None)
        # the same cells by strain: what a dense mesh shows instead of its springs
        self.strain_cell_actor = self._scalar_actor(self.cells, self.thread_scale, line_width=None, array="strain")
        self.node_actors = [
            plotter.add_mesh(poly, color=color, point_size=point_size, render_points_as_spheres=True,
                             render=False, reset_camera=False, pickable=False)
            for poly, color in ((self.boundary, YELLOW), (self.dart_pos, (1.0, 0.0, 0.0)),
                                (self.dart_neg, (0.0, 0.0, 1.0)))]
        self.topology = None
        self.frame = None
        self.options = ViewOptions()
        self.dense = False  # draw strain as coloured cells (set by the view from the springs' size on screen)
        self.set_visible(False)

    @property
    def strain_scale(self) -> ColourScale:
        """The thread scale (weft and warp springs)."""
        return self.thread_scale

    def _scalar_actor(self, poly: pv.PolyData, scale: ColourScale, line_width, array: str = "value"):
        kwargs = {"line_width": line_width} if line_width else {"show_edges": False}
        actor = self.plotter.add_mesh(poly, color="white", render=False, reset_camera=False,
                                      lighting=line_width is None, **kwargs)
        mapper = actor.GetMapper()
        mapper.SetLookupTable(scale.ctf)
        mapper.SetScalarModeToUseCellFieldData()
        mapper.SelectColorArray(array)
        mapper.SetColorModeToMapScalars()
        mapper.UseLookupTableScalarRangeOn()
        mapper.ScalarVisibilityOn()
        return actor

    # ------------------------------------------------------------------ content
    def clear(self) -> None:
        for poly in (*self.springs, self.cells, self.boundary, self.dart_pos, self.dart_neg):
            poly.copy_from(pv.PolyData(), deep=False)
        self.topology = None
        self.frame = None
        self.set_visible(False)

    @property
    def cells_show_strain(self) -> bool:
        """Strain is drawn as coloured cells now (a dense mesh with cells, strain mode)."""
        return bool(self.dense and self.options.mode not in CELL_MODES and self.cells.n_cells)

    def set_visible(self, on: bool) -> None:
        opt = self.options
        strain = opt.mode not in CELL_MODES
        as_cells = self.cells_show_strain
        for actor, kind_on in zip(self.spring_actors, opt.kinds):
            actor.SetVisibility(bool(on and strain and kind_on and not as_cells))
        self.cell_actor.SetVisibility(bool(on and not strain))
        self.strain_cell_actor.SetVisibility(bool(on and as_cells and any(opt.kinds)))
        for actor in self.node_actors:
            actor.SetVisibility(bool(on and opt.nodes))

    def _cell_group(self) -> tuple[np.ndarray, ColourScale]:
        """Which cell columns the strain cells show and on which scale: the shown
        thread kinds on the thread scale, or the diagonals when no thread is shown."""
        opt = self.options
        use = np.zeros(6, dtype=bool)
        for k in (0, 1):
            if opt.kinds[k]:
                use |= _CELL_COLUMNS[k]
        if use.any():
            return use, self.thread_scale
        return _CELL_COLUMNS[2].copy(), self.diag_scale

    def _update_strain_cells(self) -> None:
        f = self.frame
        if f is None or not self.cells.n_cells or "strain" not in self.cells.cell_data:
            return
        use, scale = self._cell_group()
        self.strain_cell_actor.GetMapper().SetLookupTable(scale.ctf)
        self.cells.cell_data["strain"][:] = cell_strain(100.0 * f.strain, self.cell_index, use)

    def _set_scales(self, options: ViewOptions) -> None:
        frame = self.frame
        strain = replace_mode(options, "strain")
        self.thread_scale.set_stops(group_stops(frame, strain, THREAD))
        self.diag_scale.set_stops(group_stops(frame, strain, DIAGONAL))
        self.shear_scale.set_stops(scale_stops(frame, replace_mode(options, "shear")))
        self.fibre_scale.set_stops(fibre_stops(frame))
        self.cell_actor.GetMapper().SetLookupTable(self.fibre_scale.ctf if options.mode == "fibre"
                                                   else self.shear_scale.ctf)

    def show(self, frame, points: np.ndarray, options: ViewOptions) -> None:
        """Draw ``frame`` with node positions ``points`` (n, 3)."""
        self.options = options
        self.frame = frame
        mesh = frame.mesh
        strain_pct = 100.0 * frame.strain
        shear = cell_values(frame, options.mode)
        self._set_scales(options)
        if frame.topology != self.topology:
            self.topology = frame.topology
            # wide lines cost a geometry-shader pass: thin ones for dense meshes (and they read better)
            width = self.line_width if mesh.n_springs <= THIN_LINES_ABOVE else 1.0
            for actor in self.spring_actors:
                actor.GetProperty().SetLineWidth(width)
            for k, poly in enumerate(self.springs):
                idx = np.flatnonzero(mesh.kind == k)
                self.spring_index[k] = idx
                replace_geometry(poly, points, lines=_line_cells(mesh.ends[idx]), scalars=strain_pct[idx])
            faces = (np.column_stack([np.full(len(mesh.cells), 4), mesh.cells]).ravel()
                     if len(mesh.cells) else None)
            replace_geometry(self.cells, points, faces=faces, scalars=shear)
            self.cell_index = cell_springs(mesh)
            if self.cells.n_cells:
                values = numpy_to_vtk(np.zeros(self.cells.n_cells), deep=True)
                values.SetName("strain")
                self.cells.GetCellData().AddArray(values)
            replace_geometry(self.boundary, points[frame.boundary], verts=True)
            replace_geometry(self.dart_pos, points[frame.dart_positive], verts=True)
            replace_geometry(self.dart_neg, points[frame.dart_negative], verts=True)
        else:
            for k, poly in enumerate(self.springs):
                if poly.n_points:
                    poly.points[:] = points
                    poly.cell_data["value"][:] = strain_pct[self.spring_index[k]]
            if self.cells.n_points:
                self.cells.points[:] = points
                self.cells.cell_data["value"][:] = shear
            for poly, idx in ((self.boundary, frame.boundary), (self.dart_pos, frame.dart_positive),
                              (self.dart_neg, frame.dart_negative)):
                if len(idx):
                    poly.points[:] = points[idx]
        if self.cells_show_strain:
            self._update_strain_cells()
        self.set_visible(True)

    def set_dense(self, dense: bool) -> bool:
        """Draw strain as cells (``dense``) or as springs; True if that changed."""
        dense = bool(dense)
        if dense == self.dense:
            return False
        self.dense = dense
        if self.frame is not None:
            if self.cells_show_strain:
                self._update_strain_cells()
            self.set_visible(True)
        return True

    def restyle(self, options: ViewOptions) -> None:
        """New options for the frame already shown (mode, kinds, thresholds)."""
        old = self.options.mode
        self.options = options
        if self.frame is not None:
            self._set_scales(options)
            if options.mode != old and self.cells.n_cells:  # shear and fibre angle share the cells
                self.cells.cell_data["value"][:] = cell_values(self.frame, options.mode)
            if self.cells_show_strain:
                self._update_strain_cells()
            self.set_visible(True)

    @property
    def active_scale(self) -> ColourScale:
        """The scale of the first colour bar (see :func:`scale_stops`)."""
        if self.options.mode == "shear":
            return self.shear_scale
        if self.options.mode == "fibre":
            return self.fibre_scale
        return self.thread_scale if (self.options.weft or self.options.warp) else self.diag_scale

    def shown_scales(self) -> list[tuple[str, ColourScale]]:
        """(group, scale) of every colour scale in use now: shear, or the thread
        and diagonal scales of the shown spring kinds."""
        opt = self.options
        if opt.mode == "shear":
            return [("shear", self.shear_scale)]
        if opt.mode == "fibre":
            return [("fibre", self.fibre_scale)]
        out = []
        if opt.weft or opt.warp:
            out.append((THREAD, self.thread_scale))
        if opt.diag and not (self.cells_show_strain and (opt.weft or opt.warp)):
            out.append((DIAGONAL, self.diag_scale))
        return out

    def scale_of_kind(self, kind: int) -> ColourScale:
        return self.diag_scale if KIND_GROUP[kind] == DIAGONAL else self.thread_scale

    # ------------------------------------------------------------------ queries
    def spring_colours(self) -> tuple[np.ndarray, np.ndarray]:
        """(springs (k,), rgb (k, 3) uint8) as the views colour them now: every
        drawn spring's index in the mesh and its colour through its kind's VTK scale."""
        idx, rgb = [], []
        for k, poly in enumerate(self.springs):
            if poly.n_cells:
                idx.append(self.spring_index[k])
                rgb.append(self.scale_of_kind(k).map(np.asarray(poly.cell_data["value"])))
        if not idx:
            return np.zeros(0, dtype=np.int64), np.zeros((0, 3), dtype=np.uint8)
        idx, rgb = np.concatenate(idx), np.concatenate(rgb)
        order = np.argsort(idx)
        return idx[order], rgb[order]

    def describe(self, actor, cell: int) -> str | None:
        """Text for the spring or cell ``cell`` of ``actor``, or None."""
        f = self.frame
        if f is None or cell < 0:
            return None
        for k, a in enumerate(self.spring_actors):
            if actor is a and cell < len(self.spring_index[k]):
                s = int(self.spring_index[k][cell])
                i, j = f.mesh.ends[s]
                lo, hi = self.scale_of_kind(k).range
                return (f"{KINDS[k]} spring {s} (nodes {i}-{j}): strain {100 * f.strain[s]:+.4f} % "
                        f"({KIND_GROUP[k]} scale {lo:+.3g} to {hi:+.3g} %), "
                        f"length {np.linalg.norm(f.xyz[i] - f.xyz[j]):.5g} / rest {f.mesh.rest[s]:.5g}")
        if actor is self.strain_cell_actor and cell < len(self.cell_index):
            use, scale = self._cell_group()
            value = float(cell_strain(100.0 * f.strain, self.cell_index[cell:cell + 1], use)[0])
            group = THREAD if scale is self.thread_scale else DIAGONAL
            lo, hi = scale.range
            return (f"cell {cell}: largest {group} strain {value:+.4f} % ({group} scale {lo:+.3g} to {hi:+.3g} %), "
                    f"shear {f.shear[cell]:+.2f} deg")
        if actor is self.cell_actor and cell < len(f.shear) and self.options.mode == "fibre":
            return (f"cell {cell}: fibre angle {cell_values(f, 'fibre')[cell]:+.2f} deg from the rosette, "
                    f"shear {f.shear[cell]:+.2f} deg")
        if actor is self.cell_actor and cell < len(f.shear):
            opt = self.options
            a = abs(float(f.shear[cell]))
            verdict = ("beyond the limit" if a > opt.shear_limit_deg else
                       "above the warning angle" if a > opt.shear_warning_deg else "fine")
            return f"cell {cell}: shear {f.shear[cell]:+.2f} deg ({verdict})"
        return None

    def pickable_actors(self) -> list:
        return [a for a in (*self.spring_actors, self.cell_actor, self.strain_cell_actor) if a.GetVisibility()]


def replace_mode(options: ViewOptions, mode: str) -> ViewOptions:
    return replace(options, mode=mode)


_IDS = itertools.count()


class ViewBase:
    """A render widget (:mod:`flatweave.app.canvas`) with hover picking over a :class:`MeshLayer`.

    ``hover_callback(text or None)`` is called (in the GUI thread) when the
    mouse moves over a spring or cell, or off them.
    """

    def __init__(self, parent=None):
        # No multisampling, one headlight, a plain background: each costs a software
        # renderer much of a render (docs/decisions/0009-window-on-software-opengl.md); a headlight also lights
        # whatever side faces the user.
        # The widget is pyvistaqt's or a raster canvas, by the renderer: see flatweave.app.canvas.
        self._plotter = make_plotter(parent)
        self._plotter.add_light(pv.Light(light_type="headlight"))
        self._plotter.set_background(BACKGROUND)
        self._closed = False
        self._name = f"view{next(_IDS)}"
        self.layer = MeshLayer(self._plotter)
        self.hover_callback: Callable[[str | None], None] | None = None
        self.hover_text: str | None = None
        self._picker = vtkCellPicker()
        self._picker.SetTolerance(0.004)
        self._last_pick = 0.0
        self._plotter.iren.add_observer("MouseMoveEvent", self._on_mouse_move)

    # ------------------------------------------------------------------ access
    @property
    def widget(self):
        """The QWidget to put in a layout."""
        return self._plotter.interactor

    @property
    def plotter(self):
        return self._plotter

    def is_ready(self) -> bool:
        """True once the GL window can render (wait for this before screenshots)."""
        return self._plotter.is_ready()

    def render(self) -> None:
        """Schedule a redraw. Both render widgets render the scene in their paint,
        so asking Qt for a repaint renders once, and repaints asked for in one
        pass of the event loop are merged (``plotter.render()`` would render
        now and then again in the repaint it schedules)."""
        if not self._closed:
            self._plotter.interactor.update()

    def render_now(self) -> None:
        """Render at once (before reading pixels back from VTK)."""
        if not self._closed:
            self._plotter.render_now()

    def screenshot(self, path) -> None:
        self._plotter.screenshot(str(path))

    def reset_camera(self) -> None:
        self._plotter.reset_camera()
        self.render()

    def device_size(self) -> tuple[int, int]:
        """(width, height) of the view in device pixels (what the render window gets)."""
        w = self.widget
        dpr = w.devicePixelRatioF()
        return max(1, round(w.width() * dpr)), max(1, round(w.height() * dpr))

    def pixels_per_unit(self) -> float:
        """Screen pixels per model unit at the camera's focal point."""
        cam = self._plotter.renderer.GetActiveCamera()
        h = self.device_size()[1]
        if cam.GetParallelProjection():
            return h / (2.0 * max(cam.GetParallelScale(), 1e-300))
        dist = max(cam.GetDistance(), 1e-300)
        return h / (2.0 * dist * math.tan(math.radians(cam.GetViewAngle()) / 2))

    def spring_pixels(self) -> float | None:
        """The shown mesh's thread spacing on screen, in pixels (None without a mesh)."""
        f = self.layer.frame
        if f is None:
            return None
        return float(min(f.mesh.r_weft, f.mesh.r_warp)) * self.pixels_per_unit()

    def update_density(self) -> bool:
        """Draw strain as coloured cells when the springs would be closer than
        ``DENSE_PIXELS`` on screen (a moire of lines otherwise); True if that changed."""
        px = self.spring_pixels()
        changed = px is not None and self.layer.set_dense(px < DENSE_PIXELS)
        if changed:
            self._density_changed()
        return changed

    def _density_changed(self) -> None:
        self.render()

    def close(self) -> None:
        """Release the render window; safe to call twice."""
        if not self._closed:
            self._closed = True
            self.hover_callback = None
            self._plotter.close()

    # ------------------------------------------------------------------ hover
    def display_point(self, xyz) -> tuple[float, float]:
        """Display coordinates (VTK's: origin bottom left) of a world point."""
        ren = self._plotter.renderer
        ren.SetWorldPoint(float(xyz[0]), float(xyz[1]), float(xyz[2]), 1.0)
        ren.WorldToDisplay()
        x, y, _ = ren.GetDisplayPoint()
        return x, y

    def describe_at(self, x: float, y: float) -> str | None:
        """What lies under display point (x, y): a spring or cell's value, or None."""
        actors = self.layer.pickable_actors()
        if not actors:
            return None
        picker = self._picker
        picker.InitializePickList()
        for a in actors:
            picker.AddPickList(a)
        picker.PickFromListOn()
        if not picker.Pick(x, y, 0.0, self._plotter.renderer):
            return None
        return self.layer.describe(picker.GetActor(), int(picker.GetCellId()))

    def _on_mouse_move(self, iren, _event) -> None:
        now = time.perf_counter()
        if now - self._last_pick < HOVER_INTERVAL:
            return
        self._last_pick = now
        x, y = iren.GetEventPosition()
        text = self.describe_at(x, y)
        if text != self.hover_text:
            self.hover_text = text
            if self.hover_callback is not None:
                self.hover_callback(text)
