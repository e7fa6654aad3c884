"""Turns document changes and solve frames into view updates.

:meth:`Presenter.document_changed` gets what a change touched as
:class:`flatweave.app.aspects.Aspect` flags and updates the 3D view, the pattern view,
the metrics, the energy plot, the panels and the status labels that show those
aspects, nothing else. The views own the VTK objects; this hands them numpy
arrays (frames) and :class:`flatweave.app.viewbase.ViewOptions`.
"""

from __future__ import annotations

from dataclasses import replace
from typing import NamedTuple

import numpy as np
from PySide6.QtGui import QCursor
from PySide6.QtWidgets import QToolTip

from flatweave.method.energy import yarn_nodes
from flatweave.errors import FlatweaveError
from flatweave.document.cutplan import SpliceReport, splice_curves
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.document.project import Project
from flatweave.document.rosettes import rosette_named
from flatweave.document.sewing import split_of
from flatweave.method.rosette import rosette, rosette_arrows, zero_angle

from flatweave.app.aspects import HISTORY, WHOLE, Aspect
from flatweave.app.colours import NOTCH, SEAM, SPLICE
from flatweave.app.frames import FrameMaker
from flatweave.app.overlay import LayerStyle
from flatweave.app.plot import result_note
from flatweave.app.tools import sew_line_uv
from flatweave.app.viewbase import ViewOptions
from flatweave.geometry.region import cover_for
from flatweave.geometry.region import loops_on_surface
from flatweave.reading.meshes import fit_mesh
from flatweave.geometry.meshfit import vertex_deviation

__all__ = ["Presenter", "SPLICES", "surface_grid", "piece_grid", "piece_surface", "PieceSurface", "PieceCut",
           "history_rows", "fit_summary", "GRID_POINTS"]

GRID_POINTS = 60
CURVE_CACHE = 256  # dart curves kept (a plane dart's takes a grid search)
KEEP_PATTERN_FOR_LIVE_FRAMES = True
KEPT_REGIONS = LayerStyle("#808080", width=2.0, closed=True)  # candidate regions kept beside the active one
OTHER_PIECES = LayerStyle("#a8a8a8", width=1.5, closed=True)  # the project's other pieces' outlines, faint
PIECE_AXES = {"piece weft": LayerStyle("#c0392b", width=3.0), "piece warp": LayerStyle("#1f5fbf", width=3.0),
              "piece zero": LayerStyle("#202020", width=2.0)}
"""The active piece's fibres at its seed (weft red, warp blue) and, when it is oriented from a
rosette, that rosette's 0-degree direction there (black): what its orientation is measured from."""
SEAMS = LayerStyle(SEAM, width=7.0)
"""The seams on the active piece's surface (issue 42): each sew line as its split cut it, wider than
the piece's outline it runs along, so both show."""
NOTCHES = LayerStyle(NOTCH, size=15.0)
"""The notches placed on the seams (the Notch tool): a bead on the seam's line, wider than it."""
SPLICES = LayerStyle(SPLICE, width=5.0)
"""The active piece's splices in the Cut plan's markers (issue 43): the lines along the roll where a piece
wider than it is cut in parts, on the surface; narrower than a seam, so a splice along a seam shows both."""
AXES_FRACTION = 0.08  # the piece's weft arrow's length, of the surface's size (the Seed tool's is 0.12)
"""A live frame without a pattern leaves the pattern view as it is when that shows a pattern (the
last result's, or an earlier frame's): it changes when the run has a pattern of its own. The first
frame of a re-solve has none (``flatweave.app.worker.FIRST_PATTERN_AT_ONCE``), and drawing its mesh in the pattern
view (the grain label placed anew, a second view repainted) was about a third of the GUI's time on it
(docs/decisions/0044-live-frames-paced-first-frame-shows-the-v.md). A paused run's frame and a dragged
point's previews go to both views as before (the designer is looking at that state)."""


def surface_grid(surface: NurbsSurface, n: int = GRID_POINTS):
    """Sample a surface on an n x n grid spanning its parameter domain.

    Returns uv : (n, n, 2), xyz : (n, n, 3), normals : (n, n, 3), with
    uv[i, j] = (u_i, v_j), u and v evenly spaced over the domain, ends included.
    """
    (u0, u1), (v0, v1) = surface.domain
    u, v = np.meshgrid(np.linspace(u0, u1, n), np.linspace(v0, v1, n), indexing="ij")
    uv = np.stack([u, v], axis=-1)
    ev = surface.evaluate(uv.reshape(-1, 2))
    return uv, ev.xyz.reshape(n, n, 3), ev.normal.reshape(n, n, 3)


def piece_grid(surface: NurbsSurface, region=None, n: int = GRID_POINTS):
    """A surface's grid (:func:`surface_grid`) cut to a trimmed piece's region
    (a :class:`flatweave.geometry.region.Region`; None: the whole domain).

    Returns uv, xyz, normals as :func:`surface_grid`, keep : (n-1, n-1) bool,
    the quads whose centres lie in the region (None untrimmed), and loops :
    the region's loops on the surface, (k, 3) each (None untrimmed)."""
    uv, xyz, normals = surface_grid(surface, n)
    if region is None:
        return uv, xyz, normals, None, None

    cover = cover_for(surface, region)
    loops = [surface.points(loop) for loop in cover.loops]
    if region.drawn is not None:  # a drawn ply: the whole surface stays in sight, to edit the boundary on it
        return uv, xyz, normals, None, loops
    centres = 0.25 * (uv[:-1, :-1] + uv[1:, :-1] + uv[1:, 1:] + uv[:-1, 1:])
    keep = cover.contains(centres.reshape(-1, 2)).reshape(n - 1, n - 1)
    return uv, xyz, normals, keep, loops


class PieceCut(NamedTuple):
    """The grid's cells a trimmed piece's loops cross, cut to the piece: ``points`` (m, 3) and
    ``normals`` (m, 3) on the surface, ``triangles`` (t, 3) indices into the grid's n * n points
    (row i * n + j) followed by these m points, each counter-clockwise in (u, v) as the grid's
    quads are, and ``cells`` (c,) the flat indices (i * (n - 1) + j) of the cells cut."""

    points: np.ndarray
    normals: np.ndarray
    triangles: np.ndarray
    cells: np.ndarray


class PieceSurface(NamedTuple):
    """What the 3D view draws of a surface (:func:`piece_surface`): ``xyz`` and ``normals``
    (n, n, 3) the grid (:func:`surface_grid`); ``keep`` (n-1, n-1) bool, the grid's quads lying
    wholly in the piece, or None: every quad; ``cut`` the quads the loops cross, cut to the piece
    (:class:`PieceCut`), or None; ``loops`` the region's loops along the surface ((k, 3) each,
    :func:`flatweave.geometry.region.loops_on_surface`), or None for the whole domain."""

    xyz: np.ndarray
    normals: np.ndarray
    keep: np.ndarray | None = None
    cut: PieceCut | None = None
    loops: list | None = None


def piece_surface(surface: NurbsSurface, region=None, n: int = GRID_POINTS) -> PieceSurface:
    """The surface as the 3D view draws it with a region (a :class:`flatweave.geometry.region.Region`; None:
    the whole domain): the piece only, the grid's quads clipped to the region in (u, v), so that
    the surface ends on its loops; a drawn region (``region.drawn``) keeps the whole surface in
    sight (the designer edits its boundary on it). The loops are sampled along the surface."""

    uv, xyz, normals = surface_grid(surface, n)
    if region is None:
        return PieceSurface(xyz, normals)
    loops = [p for _, p in loops_on_surface(surface, region)]
    if region.drawn is not None:  # a drawn ply: the whole surface stays in sight, to edit the boundary on it
        return PieceSurface(xyz, normals, loops=loops)
    keep, cut = _clip_cells(surface, cover_for(surface, region).polygon, uv)
    return PieceSurface(xyz, normals, keep, cut, loops)


def _clip_cells(surface: NurbsSurface, polygon, uv: np.ndarray) -> tuple[np.ndarray, PieceCut]:
    """(keep, cut) of the grid ``uv`` (n, n, 2) and a region's shapely ``polygon`` in (u, v):
    the quads lying in it, and those it partly covers clipped to it and triangulated
    (constrained Delaunay, so the triangles' edges follow the loops)."""
    import shapely

    n = uv.shape[0]
    u, v = uv[:, 0, 0], uv[0, :, 1]
    u0, v0 = np.meshgrid(u[:-1], v[:-1], indexing="ij")
    u1, v1 = np.meshgrid(u[1:], v[1:], indexing="ij")
    boxes = shapely.box(u0.ravel(), v0.ravel(), u1.ravel(), v1.ravel())
    inside = shapely.contains(polygon, boxes)
    cells = np.flatnonzero(shapely.intersects(polygon, boxes) & ~inside)
    parts, src = shapely.get_parts(shapely.intersection(boxes[cells], polygon), return_index=True)
    good = (shapely.get_type_id(parts) == 3) & (shapely.area(parts) > 0)  # polygons; not lines or points
    tris, tri_src = shapely.get_parts(shapely.constrained_delaunay_triangles(parts[good]), return_index=True)
    corners = shapely.get_coordinates(tris).reshape(-1, 4, 2)[:, :3]  # each ring closed: 4 points
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    twice_area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    corners = np.where((twice_area < 0)[:, None, None], corners[:, ::-1], corners)[twice_area != 0]
    pts, index = np.unique(corners.reshape(-1, 2), axis=0, return_inverse=True)
    ev = surface.evaluate(pts)
    cut = PieceCut(ev.xyz, ev.normal, n * n + index.reshape(-1, 3),
                   np.unique(cells[src[good][tri_src]][twice_area != 0]))
    return inside.reshape(n - 1, n - 1), cut


def fit_summary(fit, units: str = "m") -> str:
    """The metrics' line for a surface fitted to a mesh (:class:`flatweave.geometry.meshfit.MeshFit`):
    its largest and mean vertex deviation in model units and as a share of the mesh's size."""
    if fit is None:
        return "-"
    size = fit.size if fit.size > 0 else float("nan")
    return (f"max {fit.max_deviation:.3g} {units} ({100 * fit.max_deviation / size:.3g} %), "
            f"mean {fit.mean_deviation:.3g} {units} ({100 * fit.mean_deviation / size:.3g} %); "
            f"% of the mesh's size {fit.size:.3g} {units}")


def history_rows(history, iterations=None) -> list[tuple[float, float, bool]]:
    """The energy plot's (iteration, energy, changed) rows for a stored result's
    energy trace. The trace has one entry per snapshot, and a refill round adds
    a snapshot at the same iteration, so it can be longer than the solver's
    ``iterations``; the entries are then spread evenly over iterations 1 to
    ``iterations``, so the plot's last iteration is the metrics' count."""
    n = len(history)
    if not n:
        return []
    if not isinstance(iterations, int) or isinstance(iterations, bool) or iterations < 1 or iterations == n:
        return [(k + 1, e, False) for k, e in enumerate(history)]
    if n == 1:
        return [(float(iterations), history[0], False)]
    step = (iterations - 1) / (n - 1)
    rows = [(1 + k * step, e, False) for k, e in enumerate(history)]
    rows[-1] = (float(iterations), history[-1], False)  # exactly: the plot says int(last)
    return rows


class Presenter:
    """The window's views of the document. ``window`` gives the views, panels,
    metrics, energy plot, progress label, runner and tools; the status labels
    are ``hover``, ``name`` and ``info``."""

    def __init__(self, window, hover, name, info):
        self.window = window
        self.view, self.pattern_view = window.view, window.pattern_view
        self.hover_label, self.name_label, self.info_label = hover, name, info
        self.view_options = ViewOptions()
        self.frame = None  # the frame on screen
        self.pattern_frame = None  # the frame the pattern view shows (it may be older than ``frame``)
        self.first_nodes: int | None = None  # nodes of the run's first solver frame on its current lattice
        self.first_spacing: float | None = None  # that lattice's weft spacing (a coarse-to-fine run changes it)
        self.started_from = "the drape"  # what the run's first lattice started from ("the warm start" on a re-solve)
        self.surface_info = ""  # the surface's description (the status bar's, with no result)
        self._curve_cache: dict = {}
        self._region = None  # the trimmed piece's region drawn (None: the whole surface)
        self._fit_drawn = None  # the fitted surface whose mesh the 3D view holds (set_fit_mesh)
        self._fit_failed = None  # the fitted surface whose mesh could not be had (asked again only by its toggles)
        self.view.hover_callback = self.show_hover
        self.pattern_view.hover_callback = self.show_hover

    # ------------------------------------------------------------------ the document
    def document_changed(self, project: Project, cause: str, aspects: Aspect) -> None:
        w = self.window
        whole = cause in WHOLE
        if whole or aspects & Aspect.SURFACE:  # another document, or an older or newer state of it
            self.clear_hover()
        if aspects & Aspect.SURFACE or (aspects & Aspect.SETTINGS and project.settings.region is not self._region):
            # a drawn region edited on the same surface keeps the camera (the designer is working in it)
            drawn = [r is not None and r.drawn is not None for r in (self._region, project.settings.region)]
            # a seam drawn or taken back keeps it too (the designer is drawing on the shape, whose panels
            # the split made active)
            self._show_surface(project.surface, project.settings.region,
                               fit=bool(aspects & Aspect.SURFACE) or cause == "reset"
                               or not (any(drawn) or aspects & Aspect.SEAMS))
        if aspects & (Aspect.SETTINGS | Aspect.DISPLAY | Aspect.NAME) or whole:
            w.settings_panel.set_project(project)
        new_surface = bool(aspects & Aspect.SURFACE) or cause == "reset"
        w.tools.document_changed(cause, new_surface,
                                 cause in HISTORY and bool(aspects & (Aspect.SETTINGS | Aspect.LABELS)))
        if new_surface:
            self._curve_cache.clear()
        if aspects & (Aspect.SETTINGS | Aspect.LABELS | Aspect.SURFACE) or whole:
            w.tools.clamp_selection(len(project.settings.darts))
            w.dart_panel.set_project(project, w.tools.selected_dart)
            self.show_darts(project)
            w.tools.refresh_handles()
        if aspects & (Aspect.SETTINGS | Aspect.RESULT | Aspect.SURFACE) or whole:
            self.show_yarns(project)
        if aspects & (Aspect.PIECES | Aspect.SETTINGS | Aspect.RESULT | Aspect.SEAMS) or whole:
            w.pieces_panel.set_project(project)  # its Seams list too
        if aspects & (Aspect.PIECES | Aspect.SETTINGS | Aspect.SURFACE) or whole:
            self.show_pieces(project)
        if aspects & (Aspect.SEAMS | Aspect.PIECES | Aspect.SETTINGS | Aspect.SURFACE) or whole:
            self.show_seams(project)  # a new region redraws the surface, which clears the overlay layers
        if aspects & Aspect.RESULT:
            w.tools.result_changed()
        if aspects & (Aspect.SURFACE | Aspect.DISPLAY):
            w.metrics.set_fit(fit_summary(getattr(project.surface, "fit", None), project.units))
        if aspects & Aspect.DISPLAY:
            self.set_view_options(units=project.units, shear_warning_deg=project.shear_warning_deg,
                                  shear_limit_deg=project.shear_limit_deg)
        if cause != "result" and (aspects & (Aspect.RESULT | Aspect.SURFACE) or cause in HISTORY) \
                and not w.runner.active:
            self.show_result(project)
        elif self.frame is not None:
            w.metrics.show_frame(self.frame, project, stale=not project.result_is_current)
        self.name_label.setText(project.name)
        if not w.runner.active:  # a run's frames say how it goes; otherwise the document's state
            self.info_label.setText(self.idle_info(project))

    def idle_info(self, project: Project) -> str:
        """The status bar's right-hand text with no run in flight: the current
        result's numbers, or the surface's description when there is none."""
        r = project.result
        if r is None or r.surface is not project.surface:
            return self.surface_info
        m = r.metrics
        text = f"{m.get('iterations', 0)} iterations  EN {m.get('energy', 0):.4g}  {m.get('nodes', 0):,} nodes"
        return text if project.result_is_current else f"{text} (settings changed since)"

    def _show_surface(self, surface: NurbsSurface, region=None, fit: bool = True) -> None:
        """Draw the surface: its trimmed piece and the piece's loops when ``region`` is set
        (``fit``: frame it anew)."""
        piece = piece_surface(surface, region)
        self._region = region
        self.view.set_surface(piece.xyz, piece.normals, keep=piece.keep, loops=piece.loops, fit=fit, cut=piece.cut)
        self._fit_drawn = None  # a new surface drops the old one's mesh
        self.show_fit_mesh(surface)
        self.pattern_view.clear_frame()
        self.frame = self.pattern_frame = None
        kind = "rational" if surface.rational else "polynomial"
        (nu, nv), p, q = surface.shape, surface.degree_u, surface.degree_v
        self.surface_info = f"{kind}, degree {p}x{q}, {nu}x{nv} control points"
        if region is not None:
            self.surface_info += f", trimmed ({region.n_holes} hole{'s' if region.n_holes != 1 else ''})"
        self.info_label.setText(self.surface_info)

    # ------------------------------------------------------------------ the mesh a surface was fitted to
    def show_fit_mesh(self, surface, render: bool = True, retry: bool = True) -> bool:
        """Give the 3D view the mesh ``surface`` was fitted to, with its vertices'
        deviations, once either of its view options is on (the mesh is read
        again for a reopened project: so only on request). False, with one line
        in the status bar, when the mesh cannot be had (tried again only when
        ``retry``: its toggles, not every other view change)."""
        opts = self.view_options
        fit = getattr(surface, "fit", None)
        if fit is None or not (opts.fit_deviation or opts.fit_mesh) or self._fit_drawn is surface:
            return self._fit_drawn is surface and surface is not None
        if self._fit_failed is surface and not retry:
            return False
        try:
            mesh = fit_mesh(surface)
        except (FlatweaveError, OSError) as exc:
            self._fit_failed = surface
            self.window.statusBar().showMessage(f"Cannot show the mesh: {exc}", 10000)
            return False
        self.view.set_fit_mesh(mesh.vertices, mesh.triangles, vertex_deviation(surface, mesh))
        self._fit_drawn = surface
        if render:
            self.view.restyle(opts)
        return True

    def show_fit_deviation(self, on: bool) -> None:
        """View > Mesh fit deviation."""
        self.set_view_options(fit_deviation=bool(on))

    def show_fit_mesh_beside(self, on: bool) -> None:
        """View > Mesh beside the surface."""
        self.set_view_options(fit_mesh=bool(on))

    # ------------------------------------------------------------------ darts and yarns
    def dart_curve(self, surface: NurbsSurface, dart) -> np.ndarray:
        """(k, 3) a dart's curve on the surface (cached: a plane dart's takes a grid search)."""
        key = id(dart)
        hit = self._curve_cache.get(key)
        if hit is not None and hit[0] is dart and hit[1] is surface:
            return hit[2]
        uv = dart.curve_uv(surface)
        curve = surface.points(uv) if len(uv) else np.zeros((0, 3))
        if len(self._curve_cache) > CURVE_CACHE:
            self._curve_cache.clear()
        self._curve_cache[key] = (dart, surface, curve)
        return curve

    def show_darts(self, project: Project) -> None:
        darts = project.settings.darts
        curves = [self.dart_curve(project.surface, d) for d in darts]
        self.view.set_darts(curves, [d.visible for d in darts], self.window.tools.selected_dart)
        self.show_kept_regions(project)

    def show_kept_regions(self, project: Project) -> None:
        """The shown candidate regions' loops (flatweave.document.candidates), faint, beside the active region."""
        loops = [project.surface.points(p) for c in project.candidates
                 if c.visible and c.region is not None for p in cover_for(project.surface, c.region).loops]
        self.view.draw("kept regions", KEPT_REGIONS, loops)

    def show_pieces(self, project: Project) -> None:
        """The active piece among the others: the others' outlines faint on the tool, and at the active
        piece's seed its weft and warp and, oriented from a rosette, the rosette's 0-degree direction."""
        s = project.surface
        loops = []
        for k, piece in enumerate(project.pieces):
            region = piece.settings.region
            if k != project.piece_index and region is not None and piece.surface is s:  # on this surface
                loops.extend(self._outline(s, region))
        self.view.draw("other pieces", OTHER_PIECES, loops, render=False)
        length = AXES_FRACTION * float(np.linalg.norm(np.ptp(s.ctrlpts.reshape(-1, 3), axis=0)))
        seed = project.settings.seed
        weft, warp = rosette_arrows(rosette(s, seed, project.settings.angle_deg), length)
        self.view.draw("piece weft", PIECE_AXES["piece weft"], [weft], render=False)
        self.view.draw("piece warp", PIECE_AXES["piece warp"], [warp], render=False)
        zero = []
        if project.piece_rosette is not None:
            r = rosette_named(project.rosettes, project.piece_rosette)
            z = zero_angle(s, seed, r.zero)
            if z is not None:
                zero = [rosette_arrows(rosette(s, seed, z), 1.25 * length)[0]]
        self.view.draw("piece zero", PIECE_AXES["piece zero"], zero)

    def show_seams(self, project: Project) -> None:
        """The seams of every shape split on the active piece's surface (flatweave.document.sewing): each
        sew line of its split, sampled along the surface (:func:`flatweave.app.tools.sew_line_uv`), and
        the notches placed on them."""
        s = project.surface
        sewings = [sewing for sewing in project.sewings if sewing.surface is s]
        lines = [c for sewing in sewings for c in self._sew_lines(s, sewing)]
        notches = [q for sewing in sewings for seam in sewing.seams for q in seam.notches]
        self.view.draw("seams", SEAMS, lines, render=False)
        self.view.draw("notches", NOTCHES, (), s.points(np.array(notches, dtype=float)) if notches else None)

    def show_splices(self, project: Project | None, reports) -> None:
        """The splices ``reports`` (:class:`flatweave.document.cutplan.SpliceReport` s of the active piece, as
        :meth:`flatweave.app.cutplanview.CutPlanPanel.piece_splices` gives them) on its surface through its
        result (:func:`flatweave.document.cutplan.splice_curves`); none without a result on the surface."""
        r = None if project is None else project.result
        lines = []
        if r is not None and r.surface is project.surface:
            mm = 1000.0 * project.metres_per_unit
            lines = [c for report in reports for c in self._splice_curves(r, report, mm) if len(c)]
        if lines or len(self.view.layer_lines("splices")):  # an empty layer left empty: no render
            self.view.draw("splices", SPLICES, lines)

    def _splice_curves(self, result, report: SpliceReport, mm: float) -> list:
        """A report's splices on the surface, kept by result (immutable) and report (a value): the layer is
        drawn again at every document change."""
        key = ("splices", id(result), report, mm)
        hit = self._curve_cache.get(key)
        if hit is None or hit[0] is not result:
            if len(self._curve_cache) >= CURVE_CACHE:
                self._curve_cache.clear()
            hit = self._curve_cache[key] = (result, splice_curves(result, report, mm))
        return hit[1]

    def _sew_lines(self, surface, sewing) -> list:
        """A sewing's sew lines on the surface, (k, 3) each, kept by sewing (immutable, as its split)."""
        key = ("sew lines", id(sewing))
        hit = self._curve_cache.get(key)
        if hit is None or hit[0] is not sewing:
            if len(self._curve_cache) >= CURVE_CACHE:
                self._curve_cache.clear()
            lines = [surface.points(sew_line_uv(line.uv)) for line in split_of(sewing).sews]
            hit = self._curve_cache[key] = (sewing, lines)
        return hit[1]

    def _outline(self, surface, region) -> list:
        """A region's loops on the surface, kept by region (the others' outlines are drawn at every
        change of the active piece; a region is immutable)."""
        key = ("outline", id(surface), id(region))
        hit = self._curve_cache.get(key)
        if hit is None or hit[0] is not region:
            if len(self._curve_cache) >= CURVE_CACHE:
                self._curve_cache.clear()
            hit = self._curve_cache[key] = (region, [xyz for _, xyz in loops_on_surface(surface, region)])
        return hit[1]

    def show_yarns(self, project: Project | None, frame=None) -> None:
        if project is None:
            return
        r = project.result
        if frame is not None:
            mesh, xyz = frame.mesh, frame.xyz
        elif r is not None and r.surface is project.surface:
            mesh, xyz = r.mesh, r.xyz
        else:
            mesh = xyz = None
        lines = [] if mesh is None else [xyz[yarn_nodes(mesh, y.kind, y.index)] for y in project.settings.yarns]
        self.view.set_yarns(lines, render=frame is None)

    # ------------------------------------------------------------------ frames
    def set_view_options(self, **changes) -> None:
        self.view_options = replace(self.view_options, **changes)
        self.show_fit_mesh(None if self.window.project is None else self.window.project.surface, render=False,
                           retry=bool({"fit_deviation", "fit_mesh"} & changes.keys()))
        self.view.restyle(self.view_options)
        self.pattern_view.restyle(self.view_options)

    def show_result(self, project: Project) -> None:
        """Draw the project's result (or nothing, if it has none)."""
        w = self.window
        r = project.result
        if r is None or r.surface is not project.surface:
            self.frame = self.pattern_frame = None
            self.view.clear_frame()
            self.pattern_view.clear_frame()
            self.view.render()
            self.pattern_view.render()
            w.metrics.clear()
            w.energy_plot.clear()
            return
        frame = FrameMaker(project.surface, r.settings, r.metrics.get("boundary_length_3d"),
                           r.metrics.get("area_3d")).from_result(r)
        self.pattern_view.request_fit()
        self.draw_frame(frame)
        w.energy_plot.set_history(history_rows(r.history, r.metrics.get("iterations")), result_note(r.metrics))

    def draw_frame(self, frame) -> None:
        w = self.window
        self.frame = frame
        opts = self.view_options
        # Both views repaint in one paint pass: cheaper than a pass each
        # (docs/decisions/0009-window-on-software-opengl.md).
        self.view.show_frame(frame, opts)
        shown = self.pattern_frame
        runs = getattr(w, "runs", None)
        # a paused run shows its state, and a dragged point's preview its cut, in both views
        if not (KEEP_PATTERN_FOR_LIVE_FRAMES and frame.pattern is None and not frame.final and not frame.draping
                and shown is not None and shown.pattern is not None and not w.runner.paused
                and not (runs is not None and runs.previewing)):
            self.pattern_view.show_frame(frame, opts)
            self.pattern_frame = frame
        project = w.project
        if project is not None and project.settings.yarns:
            self.show_yarns(project, frame)
        if project is not None:
            stale = frame.final and not project.result_is_current and not w.runner.busy
            w.metrics.show_frame(frame, project, stale=stale)
        if w.runner.busy:
            w.energy_plot.set_history(w.runner.history)
            self.show_progress(frame)

    def show_progress(self, frame) -> None:
        runner = self.window.runner
        hist = runner.history
        n = frame.stats.get("nodes", 0)
        paused = " - paused" if runner.paused else ""
        if frame.draping:
            self.window.progress.setText(f"Draping{paused}: {n:,} nodes laid")
            self.info_label.setText(f"draping  {n:,} nodes")
            return
        since = self.started_from
        if self.first_nodes is None:
            self.first_nodes, self.first_spacing = n, frame.mesh.r_weft
        elif frame.mesh.r_weft != self.first_spacing:  # a coarse-to-fine run's next level: count from its start
            self.first_nodes, self.first_spacing = n, frame.mesh.r_weft
            self.started_from = since = "this level's start"
        delta = ""
        if len(hist) >= 2 and hist[-2][1] > 0:
            delta = f" (change {hist[-1][1] - hist[-2][1]:+.3g})"
        text = (f"{runner.stage.capitalize()}{paused}: iteration {frame.iteration}, "
                f"EN {frame.energy:.6g}{delta}, {n:,} nodes ({n - self.first_nodes:+,d} since {since})")
        self.window.progress.setText(text)
        self.info_label.setText(f"iteration {frame.iteration}  EN {frame.energy:.4g}  {n:,} nodes")

    def clear_hover(self) -> None:
        """Say nothing of what is under the mouse: the text told of a state no longer shown (the next
        mouse move over a spring or cell tells of the new one, even if the text is the same)."""
        for view in (self.view, self.pattern_view):
            view.hover_text = None
        self.show_hover(None)

    def show_hover(self, text: str | None) -> None:
        self.hover_label.setText(text or "")
        if text:
            QToolTip.showText(QCursor.pos(), text)
        else:
            QToolTip.hideText()
