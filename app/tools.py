"""The 3D view's tools: draw a curve dart, place a plane dart, move a curve
dart's points, pick a constrained yarn, draw a seam, notch a seam.

A tool turns mouse events in the 3D view (display coordinates, VTK's origin
bottom left) into previews drawn by the view and, when the designer commits,
into one edit of the document through :class:`flatweave.document.history.Document`'s dart,
yarn and seam methods, so undo, redo, re-runs and saving work as for any other edit.
Tools never touch VTK: they ask the view for viewing rays, display positions
and widget values, and core for the geometry (:func:`flatweave.geometry.curves.project_points`
puts a click on the surface, :func:`flatweave.method.darts.curve_dart_through` builds the
dart).

A tool's ``press``, ``move`` and ``release`` return True when they used the
event (the camera then ignores it): a click on the surface adds a point, a
drag from off the surface still turns the view.

Projection (paper 3.4 B). A click is put on the surface along its own viewing
ray (for the perspective camera, the ray from the eye through that pixel), so a
point lands exactly under the cursor. The curve between the points is the
projection of the drawn polyline along the camera's direction of projection,
which is what the paper prescribes; for a perspective view it differs slightly
from projecting every pixel along its own ray between the clicks (bound in
docs/decisions/0009-window-on-software-opengl.md), and not at all at the clicks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Protocol

import numpy as np
from scipy.spatial import cKDTree

from flatweave.geometry.curves import project_points
from flatweave.geometry.numerics import cumulative_length, interp_rows
from flatweave.method.darts import CurveDart, PlaneDart, curve_dart_through, dart_handles
from flatweave.document.history import unique_name
from flatweave.document.sewing import SeamLine, sewing_of, split_of
from flatweave.method.energy import YarnConstraint, turn_plane, yarn_index, yarn_nodes, yarn_plane
from flatweave.errors import SettingsError
from flatweave.geometry.region import check_region_size, cover_for, region_from_spec
from flatweave.method.rosette import angle_towards, rosette, rosette_arrows, seed_fraction

from flatweave.app.overlay import HANDLES, PREVIEW, LayerStyle
from flatweave.app.tooleditors import PlaneEditor, YarnEditor

__all__ = ["Tool", "ToolHost", "CurveTool", "CurveDartTool", "SeamTool", "NotchTool", "HandleEditor", "PlaneDartTool",
           "YarnTool", "PendingYarn", "RegionTool", "SeedTool", "PointsTool", "pick_surface", "sew_line_uv",
           "STROKE_PIXELS", "SNAP_PIXELS", "HANDLE_PIXELS", "NOTCH_PIXELS", "SEAM_SAMPLES", "DEFAULT_YARN_K"]

STROKE_PIXELS = 8      # a drag adds a point every this many pixels
SNAP_PIXELS = 10       # a click this close to the surface's visible rim goes onto the rim
HANDLE_PIXELS = 10     # a press this close to a handle grabs it
NOTCH_PIXELS = 10      # a click this close to a seam drawn notches it, this close to a notch removes it
SAME_PIXELS = 3        # a click this close to the last point adds nothing
DEFAULT_YARN_K = 1000.0
RIM_SAMPLES = 200      # per side of the parameter domain
PREVIEW_GRID = 128     # the plane dart preview's parameter grid (the solve's curve uses 256)
SEAM_SAMPLES = 256     # points added along a sew line, so a straight (u, v) stretch follows the surface


def pick_surface(surface, view, x: float, y: float):
    """The surface point under display point (x, y): ((u, v), xyz) of the first
    hit along the pixel's viewing ray in front of the camera, or None (a miss)."""
    origin, direction = view.pick_ray(x, y)
    pr = project_points(surface, origin[None, :], direction)
    if not pr.hit[0] or pr.t[0] < 0:
        return None
    return pr.uv[0], pr.xyz[0]


def sew_line_uv(uv) -> np.ndarray:
    """(k, 2) a sew line's (u, v) polyline ``uv`` with SEAM_SAMPLES points added evenly along it (its own
    points among them): the points the 3D view draws it through (mapped onto the surface), so a straight
    (u, v) stretch follows the surface, and the Notch tool picks it at."""
    uv = np.asarray(uv, dtype=float)
    s = cumulative_length(uv)
    return interp_rows(np.union1d(s, np.linspace(0.0, s[-1], SEAM_SAMPLES)), s, uv)


def _rim(surface) -> tuple[np.ndarray, np.ndarray]:
    """(k, 2) and (k, 3): points along the boundary of the parameter domain."""
    (u0, u1), (v0, v1) = surface.domain
    t = np.linspace(0.0, 1.0, RIM_SAMPLES, endpoint=False)
    uv = np.concatenate([
        np.column_stack([u0 + t * (u1 - u0), np.full_like(t, v0)]),
        np.column_stack([np.full_like(t, u1), v0 + t * (v1 - v0)]),
        np.column_stack([u1 - t * (u1 - u0), np.full_like(t, v1)]),
        np.column_stack([np.full_like(t, u0), v1 - t * (v1 - v0)]),
    ])
    return uv, surface.points(uv)


class ToolHost(Protocol):
    """What a tool may ask of the window (``flatweave.app.tooling.WindowToolHost`` is the window's).

    view : the 3D view (``flatweave.app.view3d.SurfaceView``): viewing rays, display
        points, overlay layers (``draw``) and the plane and box widgets
    document : the open ``flatweave.document.history.Document``: every commit is one of its edits
    """

    view: Any

    @property
    def document(self) -> Any: ...

    def hint(self, text: str) -> None:
        """Tell the designer what to do next (the status bar)."""

    def drop_tool(self) -> None:
        """End the active tool (the window falls back to the selection's, if any)."""

    def preview_dart(self, index: int, dart) -> None:
        """Re-solve with dart ``index`` replaced by ``dart``, outside the document (a drag in progress)."""

    def preview_settings(self, **changes) -> None:
        """Re-solve with these settings changed, outside the document (a region point being dragged)."""

    def end_preview(self) -> None:
        """The drag's preview is over without an edit: show the document again."""

    def show_editor(self, tool: Tool) -> None:
        """Show ``tool``'s editor (its class ``tool.editor``) filled from the tool."""

    def hide_editor(self, tool: Tool) -> None:
        """Hide ``tool``'s editor."""


class Tool:
    """A tool of the 3D view (see the module docstring), working for ``host``.

    What the window asks of every tool is here, so it never checks a tool's
    class: the mouse (``press``, ``move``, ``release``), the keys (``finish``,
    ``cancel``, ``back``), a new result (``on_result``), its editor's reports
    (``on_editor``) and an item of the document to edit (``edit``).

    A tool declares what it draws and edits:

    layers : {name: :class:`~flatweave.app.overlay.LayerStyle`}, the 3D view's
        overlay layers the tool draws (``draw``); the window clears them when
        the tool ends, so a tool never leaves a drawing behind
    editor : the :class:`~flatweave.app.tooleditors.ToolEditor` class the darts
        panel shows for it (``show_editor``), or None
    edits : the kinds of document item it edits (``"plane dart"``, ``"curve
        dart"``, ``"yarn"``): the panel's Edit on such an item makes this tool
        and calls ``edit(index)`` (an ``implied`` tool is made for the selected
        item instead, as ``cls(host, index)``, when ``wants(document, index)``)
    """

    name = "tool"
    implied = False     # comes and goes with the dart selection (not chosen): Finish and Cancel do not apply
    takes_back = False  # Backspace takes back a step
    layers: dict[str, LayerStyle] = {"preview": PREVIEW, "handles": HANDLES}
    editor: type | None = None
    edits: tuple[str, ...] = ()

    def __init__(self, host: ToolHost):
        self.host = host
        self.view = host.view

    @property
    def document(self):
        return self.host.document

    @property
    def surface(self):
        return self.host.document.project.surface

    def hint(self, text: str) -> None:
        self.host.hint(text)

    def activate(self) -> None:
        pass

    def deactivate(self) -> None:
        pass

    def press(self, x: float, y: float, double: bool) -> bool:
        return False

    def move(self, x: float, y: float) -> bool:
        return False

    def release(self, x: float, y: float) -> bool:
        return False

    def finish(self) -> bool:
        """Enter: commit what the tool holds (False when there is nothing to commit)."""
        return False

    def cancel(self) -> None:
        """Esc: drop what the tool holds."""

    def back(self) -> None:
        """Backspace: take back the last step (see ``takes_back``)."""

    def on_result(self) -> None:
        """The document's result changed (a solve ended, or undo)."""

    def on_editor(self, values: dict) -> None:
        """What the designer changed in the tool's editor (keys are the editor's)."""

    def edit(self, index: int) -> None:
        """Load item ``index`` of a kind in ``edits`` for editing (called after ``activate``)."""

    @classmethod
    def wants(cls, document, index: int) -> bool:
        """Whether an ``implied`` tool is made for selected item ``index``."""
        return False

    # -------------------------------------------------------------- drawing and the editor
    def draw(self, name: str, lines=(), points=None, render: bool = True) -> None:
        """Draw layer ``name`` (one of ``layers``): polylines (k, 3) each and points (j, 3)."""
        self.view.draw(name, self.layers[name], lines, points, render)

    def draw_preview(self, curve=None, points=None, render: bool = True) -> None:
        """The preview: what the tool would make (a curve (k, 3)) and its points (j, 3); no arguments clear it."""
        self.draw("preview", [] if curve is None else [curve], points, render)

    def draw_handles(self, points=None, render: bool = True) -> None:
        """Draggable handles at ``points`` (h, 3); None hides them."""
        self.draw("handles", (), points, render)

    def clear_drawing(self) -> None:
        """Empty every layer of the tool's."""
        self.view.clear_layers(self.layers, render=True)

    def show_editor(self) -> None:
        self.host.show_editor(self)

    def hide_editor(self) -> None:
        self.host.hide_editor(self)

    def _rim_point(self, x: float, y: float):
        """The visible rim point within SNAP_PIXELS of (x, y): ((u, v), xyz), or None."""
        uv, xyz = _rim(self.surface)
        disp = self.view.display_points(xyz)
        dist = np.hypot(disp[:, 0] - x, disp[:, 1] - y)
        scale = float(np.linalg.norm(np.ptp(xyz, axis=0)))
        for k in np.argsort(dist)[:8]:
            if dist[k] > SNAP_PIXELS:
                break
            if self._in_sight(xyz[k], disp[k], scale):
                return uv[k], xyz[k]
        return None

    def _in_sight(self, xyz, at, scale: float) -> bool:
        """Whether the surface's point ``xyz`` (3,), seen at display point ``at``, is in sight: nothing of
        the surface lies in front of it along that pixel's ray (``scale``: the surface's size, for the
        tolerance)."""
        origin, direction = self.view.pick_ray(*at)
        pr = project_points(self.surface, origin[None, :], direction)
        depth = float((np.asarray(xyz, dtype=float) - origin) @ direction)
        return not pr.hit[0] or pr.t[0] >= depth - 1e-3 * scale


# ---------------------------------------------------------------------- drawing by points
class PointsTool(Tool):
    """What the curve dart and region tools share: points placed by clicks on
    the surface (under the cursor; just off the visible rim, onto the rim),
    one list of what each click placed (``placed``, the subclass's form) and
    of its pixel, Esc dropping them, Backspace taking back the last."""

    takes_back = True
    what = "points"  # "Dart cancelled." / "Region cancelled."

    def __init__(self, host):
        super().__init__(host)
        self.placed: list[np.ndarray] = []
        self.pixels: list[tuple[float, float]] = []

    def _same_as_last(self, x, y) -> bool:
        return bool(self.pixels) and math.hypot(x - self.pixels[-1][0], y - self.pixels[-1][1]) < SAME_PIXELS

    def _hit(self, x, y):
        """((u, v), xyz, snapped) of the surface under (x, y), or of the rim just beside it; None: a miss."""
        hit = pick_surface(self.surface, self.view, x, y)
        if hit is not None:
            return hit[0], hit[1], False
        hit = self._rim_point(x, y)
        return None if hit is None else (hit[0], hit[1], True)

    def _place(self, value, x, y) -> None:
        self.placed.append(np.asarray(value, dtype=float))
        self.pixels.append((float(x), float(y)))
        self._update_preview()

    def _update_preview(self) -> None:
        raise NotImplementedError

    def cancel(self, quiet: bool = False) -> None:
        had = bool(self.placed)
        self._clear()
        if had and not quiet:
            self.hint(f"{self.what.capitalize()} cancelled.")

    def back(self) -> None:
        if self.placed:
            self.placed.pop()
            self.pixels.pop()
            self._update_preview()

    def _clear(self) -> None:
        self.placed.clear()
        self.pixels.clear()
        self.preview = None
        self.draw_preview()


# ---------------------------------------------------------------------- curves drawn by points: darts, seams
class CurveTool(PointsTool):
    """What the curve dart and seam tools share: clicks (or drags) add points on
    the surface (just off the rim, onto it), and the curve through them, the
    polyline through their points projected along the view and fitted by biarcs
    (:func:`flatweave.method.darts.curve_dart_through`), is previewed as it
    grows; Enter or a double click finishes (``finish``: the subclass's edit),
    Esc cancels, Backspace removes the last point."""

    what = "curve"  # "dart", "seam": what the hints call the thing made

    def __init__(self, host):
        super().__init__(host)
        self.dragging = False
        self.preview: CurveDart | None = None
        self._preview_of = None  # (handles, view direction) the preview was made from

    @property
    def handles(self) -> list[np.ndarray]:
        """(u, v) of the points placed."""
        return self.placed

    def deactivate(self) -> None:
        self.cancel(quiet=True)

    # -------------------------------------------------------------- events
    def press(self, x, y, double):
        if double and self.pixels and math.hypot(x - self.pixels[-1][0], y - self.pixels[-1][1]) <= 6:
            self.finish()
            return True
        added = self._add(x, y, explain=True)
        if double and added:
            self.finish()
            return True
        self.dragging = added
        return added

    def move(self, x, y):
        if not self.dragging:
            return False
        if self.pixels and math.hypot(x - self.pixels[-1][0], y - self.pixels[-1][1]) >= STROKE_PIXELS:
            self._add(x, y, explain=False)
        return True

    def release(self, x, y):
        if not self.dragging:
            return False
        self.dragging = False
        return True

    def _add(self, x, y, explain: bool) -> bool:
        if self._same_as_last(x, y):
            return True  # the same point again: nothing new, but the click is ours
        hit = self._hit(x, y)
        if hit is None:
            if explain:
                self.hint("That click missed the surface: no point added. Click on the surface "
                          f"(Esc cancels the {self.what}).")
            return False
        self._place(hit[0], x, y)
        n = len(self.handles)
        where = "on the edge" if hit[2] else "on the surface"
        self.hint(f"Point {n} {where}. " + ("Click the next point." if n < 2 else
                                            f"Click more points, or Enter to make the {self.what}."))
        return True

    # -------------------------------------------------------------- the curve
    def _update_preview(self) -> None:
        s = self.surface
        pts = s.points(np.array(self.handles)) if self.handles else None
        self.preview = None
        curve = None
        if len(self.handles) >= 2:
            try:
                self._preview_of = (np.array(self.handles), self.view.view_direction())
                self.preview = curve_dart_through(s, *self._preview_of)
                curve = s.points(self.preview.uv)
            except SettingsError as exc:
                self.hint(self._said(exc))
                curve = pts
        self.draw_preview(curve, pts)

    def _said(self, exc: SettingsError) -> str:
        """A refused curve's message, as the hint says it."""
        return str(exc)

    def _curve(self, name: str) -> CurveDart:
        """The curve through the points placed, seen along the view now, named ``name``: the
        preview's when it was made from the same points and view (projection and fit are 10-25 ms
        of the GUI's before a re-solve can start). A SettingsError when none goes through them."""
        handles, view_dir = np.array(self.handles), self.view.view_direction()
        if self.preview is not None and all(np.array_equal(x, y) for x, y in
                                            zip(self._preview_of, (handles, view_dir))):
            return replace(self.preview, name=name)
        return curve_dart_through(self.surface, handles, view_dir, name=name)

    def _clear(self) -> None:
        super()._clear()
        self.dragging = False


class CurveDartTool(CurveTool):
    """Draw a curve dart: clicks (or drags) add points on the surface, Enter or
    a double click finishes, Esc cancels, Backspace removes the last point."""

    name = "curve dart"
    what = "dart"

    def activate(self) -> None:
        self.hint("Curve dart: click points on the surface (or drag a stroke); Enter or a double click "
                  "finishes, Esc cancels, Backspace takes back a point. Drag off the surface to turn the view.")

    def finish(self) -> bool:
        if len(self.handles) < 2:
            self.hint("A curve dart needs at least two points on the surface.")
            return False
        doc = self.document
        name = unique_name("curve dart", (d.name for d in doc.project.settings.darts))
        try:
            dart = self._curve(name)
        except SettingsError as exc:
            self.hint(f"Cannot make the dart: {exc}")
            return False
        self._clear()
        doc.add_dart(dart)
        self.hint(f"Added {name}.")
        return True


class SeamTool(CurveTool):
    """Draw a seam (issue 42): clicks (or drags) add points on the surface, from an
    edge to an edge or another seam (a click just off the rim goes onto it); Enter
    or a double click finishes, Esc cancels, Backspace removes the last point.

    The seam is the curve a curve dart through the same points would run along
    (:class:`CurveTool`), as a :class:`flatweave.document.sewing.SeamLine` named
    "seam N", and finishing is one :meth:`flatweave.document.history.Document.add_seam`
    on the active piece: its first seam splits it into panels, which replace it
    as pieces; a later one re-splits its shape. A seam the split refuses (it
    crosses itself, leaves a free end inside a panel, makes a sliver) is said as
    the tool's one-line hint, the points kept to take back or redraw, and the
    document does not change."""

    name = "seam"
    what = "seam"

    def _said(self, exc: SettingsError) -> str:
        # the curve's fit (curve_dart_through) words its refusals for a curve dart
        return str(exc).replace("a curve dart", "a seam").replace("the dart's", "the seam's")

    def activate(self) -> None:
        self.hint("Seam: click points on the surface from an edge to an edge (or to another seam); Enter or a "
                  "double click finishes, Esc cancels, Backspace takes back a point.")

    def finish(self) -> bool:
        if len(self.handles) < 2:
            self.hint("A seam needs at least two points on the surface.")
            return False
        doc = self.document
        project = doc.project
        sewing = sewing_of(project, project.piece_index)
        name = unique_name("seam", () if sewing is None else (s.name for s in sewing.seams))
        try:
            seam = SeamLine(name, self._curve(name).uv)
            doc.add_seam(seam)
        except SettingsError as exc:
            self.hint(f"Cannot make the seam: {self._said(exc)}")
            return False
        self._clear()
        project = doc.project
        sewing = sewing_of(project, project.piece_index)
        panels = 1 if sewing is None else len(sewing.panels)
        self.hint(f"Added {name}: {panels} panels.")
        return True


NOTCH_CANDIDATES = 16  # the nearest seam points (or notches) on screen tried for one in sight


class NotchTool(Tool):
    """Notch a seam (issue 42): a click on a seam drawn on the surface (within
    NOTCH_PIXELS of its line on screen; a stretch the surface hides is not
    picked) adds a notch at the seam's point nearest the click, and a click on
    a notch (within as many pixels) removes it, each one
    :meth:`flatweave.document.history.Document.edit_seam` of the seam's notches
    ("Add notch", "Remove notch"; notches are labels: no re-split, no solve).
    Both panels of the seam get a notch there in the cut files
    (:func:`flatweave.document.sewing.sew_marks`). A click away from every seam
    says so as the tool's hint and changes nothing (a drag from there turns the
    view); a double click's second press does nothing (the first placed or
    removed the notch). The seams of the active piece's surface and their notches are the
    window's drawing (the presenter's "seams" and "notches" layers, redrawn
    with every seam edit), so the tool draws nothing of its own."""

    name = "notch"
    layers: dict[str, LayerStyle] = {}

    def activate(self) -> None:
        self.hint("Notch: click on a seam to put a notch there (both panels get one in the cut files), click a "
                  "notch to remove it. Drag off the seams to turn the view.")

    def _sewings(self) -> list:
        """The shapes split by seams on the active piece's surface: those whose seams are drawn."""
        project = self.document.project
        return [s for s in project.sewings if s.surface is project.surface]

    def press(self, x, y, double):
        if double:
            return True
        sewings = self._sewings()
        if not any(s.seams for s in sewings):
            self.hint("No seams on this surface: draw one with the Seam tool, then notch it.")
            return False
        scale = float(np.linalg.norm(np.ptp(_rim(self.surface)[1], axis=0)))
        at = self._notch_at(sewings, x, y, scale)
        if at is not None:
            sewing, seam, k = at
            return self._commit(sewing, seam, seam.notches[:k] + seam.notches[k + 1:], "Remove notch",
                                f"Removed a notch from {seam.name}")
        near = self._seam_at(sewings, x, y, scale)
        if near is None:
            self.hint(f"No seam there (none within {NOTCH_PIXELS} pixels): click on a seam to notch it, or on a "
                      "notch to remove it; nothing changed.")
            return False
        sewing, seam, uv = near
        return self._commit(sewing, seam, seam.notches + ((float(uv[0]), float(uv[1])),), "Add notch",
                            f"Added a notch to {seam.name}")

    def _commit(self, sewing, seam, notches: tuple, label: str, done: str) -> bool:
        """One edit ``label`` giving ``seam`` of ``sewing`` these ``notches``; the hint says ``done``, or why not."""
        try:
            self.document.edit_seam(sewing.name, seam.name, label=label, notches=notches)
        except SettingsError as exc:
            self.hint(f"Cannot {label.lower()}: {exc}")
            return True
        self.hint(f"{done}: {len(notches)} on it besides its ends. Click a notch to remove it.")
        return True

    def _notch_at(self, sewings, x, y, scale: float):
        """(sewing, seam, k): the notch in sight nearest display point (x, y) within NOTCH_PIXELS, or None."""
        notches = [(sewing, seam, k) for sewing in sewings for seam in sewing.seams for k in range(len(seam.notches))]
        if not notches:
            return None
        xyz = self.surface.points(np.array([seam.notches[k] for _, seam, k in notches], dtype=float))
        disp = self.view.display_points(xyz)
        dist = np.hypot(disp[:, 0] - x, disp[:, 1] - y)
        for j in np.argsort(dist)[:NOTCH_CANDIDATES]:
            if dist[j] > NOTCH_PIXELS:
                break
            if self._in_sight(xyz[j], disp[j], scale):
                return notches[j]
        return None

    def _seam_at(self, sewings, x, y, scale: float):
        """(sewing, seam, (u, v)): the seam in sight nearest display point (x, y) within NOTCH_PIXELS, and
        its point nearest it on screen (on the sew line's (u, v) polyline, as drawn); or None."""
        p = np.array([x, y], dtype=float)
        found = []  # per sew line: its sewing, its seam, (u, v) samples, display points, t, distance
        for sewing in sewings:
            seams = {seam.name: seam for seam in sewing.seams}
            for line in split_of(sewing).sews:
                uv = sew_line_uv(line.uv)
                disp = self.view.display_points(self.surface.points(uv))
                t, dist = _segment_nearest(p, disp[:-1], disp[1:])
                found.append((sewing, seams[line.seam], uv, disp, t, dist))
        if not found:
            return None
        owner = np.concatenate([np.full(len(f[5]), k) for k, f in enumerate(found)])
        segment = np.concatenate([np.arange(len(f[5])) for f in found])
        dist = np.concatenate([f[5] for f in found])
        for j in np.argsort(dist, kind="stable")[:NOTCH_CANDIDATES]:
            if dist[j] > NOTCH_PIXELS:
                break
            sewing, seam, uv, disp, t, _ = found[owner[j]]
            i, f = segment[j], t[segment[j]]
            at = (1.0 - f) * uv[i] + f * uv[i + 1]
            if self._in_sight(self.surface.points(at[None])[0], (1.0 - f) * disp[i] + f * disp[i + 1], scale):
                return sewing, seam, at
        return None


class HandleEditor(Tool):
    """Move the points of the selected curve dart: drag a handle across the
    surface. While it moves, the dart through the points (projected along the
    current view direction) is re-solved as a preview (``host.preview_dart``,
    not an edit; the newest position wins); on release it replaces the old
    dart as one edit, which the preview of that position answers."""

    name = "dart points"
    implied = True
    edits = ("curve dart",)

    @classmethod
    def wants(cls, document, index: int) -> bool:
        dart = document.project.settings.darts[index]
        return dart.editable_points and dart.visible

    def __init__(self, host, index: int):
        super().__init__(host)
        self.index = index
        dart = self.document.project.settings.darts[index]
        self.dart = dart
        self.handles = dart_handles(self.surface, dart)
        self.grabbed: int | None = None
        self.moved = False
        self.previewing = False  # a preview of an uncommitted position was asked for

    def activate(self) -> None:
        self.draw_handles(self.surface.points(self.handles))
        self.hint(f"{self.dart.name}: drag its points (the squares) on the surface.")

    def deactivate(self) -> None:
        self.draw_handles()
        self.draw_preview()
        self._end_preview()

    def _end_preview(self) -> None:
        if self.previewing:
            self.previewing = False
            self.host.end_preview()

    def _dart(self) -> CurveDart:
        """The dart through the handles as they are now (SettingsError if none goes through them)."""
        d = self.dart
        return curve_dart_through(self.surface, self.handles, self.view.view_direction(), name=d.name,
                                  visible=d.visible)

    def press(self, x, y, double):
        disp = self.view.display_points(self.surface.points(self.handles))
        dist = np.hypot(disp[:, 0] - x, disp[:, 1] - y)
        k = int(np.argmin(dist))
        if dist[k] > HANDLE_PIXELS:
            return False
        self.grabbed, self.moved = k, False
        return True

    def move(self, x, y):
        if self.grabbed is None:
            return False
        hit = pick_surface(self.surface, self.view, x, y)
        if hit is None:
            return True  # off the surface: the point stays where it was
        self.handles[self.grabbed] = hit[0]
        self.moved = True
        pts = self.surface.points(self.handles)
        try:
            dart = self._dart()
        except SettingsError:
            dart, curve = None, pts
        else:
            curve = self.surface.points(dart.uv)
        self.draw_handles(pts, render=False)
        self.draw_preview(curve, None)
        if dart is not None:
            self.previewing = True
            self.host.preview_dart(self.index, dart)
        return True

    def release(self, x, y):
        if self.grabbed is None:
            return False
        self.grabbed = None
        if self.moved:
            self.commit()
        return True

    def commit(self) -> bool:
        """Rebuild the dart through the handles and make it an edit (the preview of
        the same position, if one runs, answers it)."""
        d = self.dart
        try:
            new = self._dart()
        except SettingsError as exc:
            self.hint(f"Cannot move the point: {exc}")
            self.handles = dart_handles(self.surface, d)
            self.draw_handles(self.surface.points(self.handles))
            self.draw_preview()
            self._end_preview()
            return False
        self.draw_preview()
        self.previewing = False  # the edit takes the preview over (or re-runs)
        if self.document.replace_dart(self.index, new, label=f"Move {d.name}") is None:
            self.host.end_preview()  # the same dart as before: no edit, nothing to answer
        return True


# ---------------------------------------------------------------------- plane darts
class PlaneDartTool(Tool):
    """Place a plane dart with the plane and box widgets or numbers; the
    plane's curve on the surface is previewed; Apply (or Enter) adds it, or
    replaces dart ``index`` when editing one."""

    name = "plane dart"
    editor = PlaneEditor
    edits = ("plane dart",)

    def __init__(self, host):
        super().__init__(host)
        self.index: int | None = None  # the dart edited, or None for a new one
        s = self.surface
        (u0, u1), (v0, v1) = s.domain
        g = np.linspace(0, 1, 33)
        U, V = np.meshgrid(u0 + g * (u1 - u0), v0 + g * (v1 - v0), indexing="ij")
        xyz = s.points(np.column_stack([U.ravel(), V.ravel()]))
        lo, hi = xyz.min(axis=0), xyz.max(axis=0)
        pad = 0.05 * float(np.linalg.norm(hi - lo))
        self.bounds = np.ravel(np.column_stack([lo - pad, hi + pad]))  # the widgets' room
        # across the longest extent, through the middle; the box keeps the lower 60 % of the
        # next longest, so the dart starts at the rim and ends inside (move both to taste)
        order = np.argsort(-(hi - lo), kind="stable")
        axis = np.zeros(3)
        axis[order[0]] = 1.0
        centre = 0.5 * (lo + hi)
        self.plane = (*(float(a) for a in axis), float(-axis @ centre))
        blo, bhi = lo - 0.01 * pad, hi + 0.01 * pad
        bhi[order[1]] = lo[order[1]] + 0.6 * (hi - lo)[order[1]]
        self.box = tuple(float(b) for b in np.ravel(np.column_stack([blo, bhi])))
        self.dart_name = unique_name("plane dart", (d.name for d in self.document.project.settings.darts))
        self.dart: PlaneDart | None = None
        self.curve = np.zeros((0, 3))

    def edit(self, index: int) -> None:
        """Move plane dart ``index``: its plane and box in the widgets and the editor; Apply replaces it."""
        d = self.document.project.settings.darts[index]
        self.index, self.dart_name = index, d.name
        self.set_values(tuple(float(x) for x in d.plane), None if d.box is None else tuple(float(x) for x in d.box))
        self.hint(f"Moving {d.name}: drag the plane and the box, or type the numbers; Apply or Enter replaces "
                  "the dart, Esc cancels.")

    # -------------------------------------------------------------- state
    def activate(self) -> None:
        origin, normal = self._origin_normal()
        self.view.show_plane_widget(origin, normal, self.bounds, self._plane_moved)
        if self.box is not None:
            self.view.show_box_widget(self.box, self._box_moved)
        self._changed(from_widgets=False)
        self.hint("Plane dart: drag the plane (its arrow turns it) and the box's faces, or type the numbers; "
                  "Apply or Enter adds the dart, Esc cancels.")

    def deactivate(self) -> None:
        self.view.hide_plane_widget()
        self.view.hide_box_widget()
        self.draw_preview()
        self.hide_editor()

    def _origin_normal(self):
        p = np.asarray(self.plane, dtype=float)
        n = p[:3] / np.linalg.norm(p[:3])
        centre = 0.5 * (self.bounds[0::2] + self.bounds[1::2])
        origin = centre - (p[:3] @ centre + p[3]) / np.linalg.norm(p[:3]) * n
        return origin, n

    def _plane_moved(self, origin, normal) -> None:
        n = np.asarray(normal, dtype=float)
        n = n / np.linalg.norm(n)
        self.plane = (float(n[0]), float(n[1]), float(n[2]), float(-n @ np.asarray(origin, dtype=float)))
        self._changed(from_widgets=True)

    def _box_moved(self, bounds) -> None:
        self.box = tuple(float(b) for b in bounds)
        self._changed(from_widgets=True)

    def on_editor(self, values: dict) -> None:
        self.set_values(values["plane"], values["box"])

    def set_values(self, plane, box) -> bool:
        """Numbers typed in the panel: the plane (a, b, c, d) and the box (6) or None."""
        try:
            dart = PlaneDart(tuple(plane), None if box is None else tuple(box), name=self.dart_name)
        except SettingsError as exc:
            self.hint(str(exc))
            self.show_editor()
            return False
        self.plane, self.box = dart.plane, dart.box
        origin, normal = self._origin_normal()
        self.view.set_plane_widget(origin, normal)
        if self.box is None:
            self.view.hide_box_widget()
        elif self.view.box_widget is None:
            self.view.show_box_widget(self.box, self._box_moved)
        else:
            self.view.set_box_widget(self.box)
        self._changed(from_widgets=False)
        return True

    def _changed(self, from_widgets: bool) -> None:
        try:
            self.dart = PlaneDart(self.plane, self.box, name=self.dart_name)
        except SettingsError as exc:  # a box squeezed flat, say
            self.dart = None
            self.hint(str(exc))
            return
        s = self.surface
        uv = self.dart.curve_uv(s, PREVIEW_GRID)
        self.curve = s.points(uv) if len(uv) >= 2 else np.zeros((0, 3))
        self.draw_preview(self.curve if len(self.curve) else None)
        if not len(self.curve):
            self.hint("The plane does not meet the surface inside the box.")
        self.show_editor()

    # -------------------------------------------------------------- commit
    def finish(self) -> bool:
        if self.dart is None or len(self.curve) < 2:
            self.hint("The plane does not meet the surface inside the box: nothing to add.")
            return False
        doc = self.document
        if self.index is None:
            doc.add_dart(self.dart)
        else:
            old = doc.project.settings.darts[self.index]
            doc.replace_dart(self.index, replace(self.dart, name=old.name, visible=old.visible),
                             label=f"Move {old.name}")
        self.host.drop_tool()
        return True

    def cancel(self) -> None:
        self.host.drop_tool()


# ---------------------------------------------------------------------- yarns
@dataclass
class PendingYarn:
    """A yarn picked but not yet constrained.

    node : the picked node (the anchor); kind, index : its weft row or warp column
    base : the plane an angle of 0 means (the default plane, or the constraint's own)
    angle_deg, k : the designer's choices; replaces : the constraint edited, or None
    ij : the node's lattice position (to find it again in a new mesh)
    """

    node: int
    kind: str
    index: int
    base: tuple | None
    angle_deg: float = 0.0
    k: float = DEFAULT_YARN_K
    replaces: int | None = None
    ij: tuple | None = None
    point: tuple | None = None  # what the designer picked: the yarn is found through it after every drape


class YarnTool(Tool):
    """Pick a constrained yarn: click a node of the solved mesh, choose its weft
    row or warp column, the angle of its plane and its weight; Apply (or
    Enter) adds the constraint. The default plane runs through the yarn's end
    points and contains the surface normal at the picked node; the angle turns
    it about that normal."""

    name = "yarn"
    editor = YarnEditor
    edits = ("yarn",)
    layers = {**Tool.layers, "picked yarn": LayerStyle("#00a0d0", width=6.0, size=16.0)}

    def __init__(self, host):
        super().__init__(host)
        self.pending: PendingYarn | None = None
        self.plane: tuple | None = None
        self._tree = None
        self._tree_of = None

    @property
    def result(self):
        return self.document.project.result

    def activate(self) -> None:
        if self.result is None:
            self.hint("Run a solve first: yarns are picked on the mesh's nodes.")
        else:
            self.hint("Yarn: click a node of the mesh, choose its weft row or warp column, then Apply.")

    def deactivate(self) -> None:
        self.pending = None
        self.draw("picked yarn")
        self.draw_preview()
        self.hide_editor()

    def press(self, x, y, double):
        r = self.result
        if r is None:
            self.hint("Run a solve first: yarns are picked on the mesh's nodes.")
            return False
        hit = pick_surface(self.surface, self.view, x, y)
        if hit is None:
            self.hint("That click missed the surface: pick a node of the mesh.")
            return False
        if self._tree_of is not r:
            self._tree, self._tree_of = cKDTree(r.xyz), r
        dist, node = self._tree.query(hit[1])
        if dist > float(np.hypot(r.mesh.r_weft, r.mesh.r_warp)):
            self.hint("No node there: pick a node of the mesh.")
            return False
        kind = self.pending.kind if self.pending is not None and self.pending.replaces is None else "weft"
        self.pick(int(node), kind)
        return True

    def on_editor(self, values: dict) -> None:
        self.set_choice(**values)

    def on_result(self) -> None:
        """A new result (a solve ended, or undo): the picked node is found again
        by its lattice position, or the pick is dropped if the mesh lost it."""
        p, r = self.pending, self.result
        if p is None:
            return
        if r is None or p.ij is None:
            self.cancel()
            return
        same = np.flatnonzero(np.all(r.mesh.ij == np.asarray(p.ij), axis=1))
        if not len(same):
            self.cancel()
            self.hint("The picked node is gone from the new mesh; pick again.")
            return
        p.node = int(same[0])
        self.update()

    def pick(self, node: int, kind: str = "weft") -> None:
        """Pick ``node``'s weft row or warp column (with the default plane)."""
        mesh, xyz = self.result.mesh, self.result.xyz
        self.pending = PendingYarn(node, kind, yarn_index(mesh, node, kind), None, ij=tuple(mesh.ij[node]),
                                   point=tuple(float(c) for c in xyz[node]))
        self.update()

    def edit(self, index: int) -> None:
        """Load constraint ``index`` for editing (its plane is the angle's zero)."""
        y = self.document.project.settings.yarns[index]
        r = self.result
        if r is None:
            self.hint("Run a solve first: the constraint's yarn is shown on the mesh.")
            return
        y = y.resolved(r.mesh, r.xyz)  # its row in this mesh (a picked yarn is found by its point)
        nodes = yarn_nodes(r.mesh, y.kind, y.index)
        if not len(nodes):
            self.hint(f"The mesh has no {y.label()} now; remove the constraint or run again.")
            return
        anchor = int(nodes[len(nodes) // 2])
        self.pending = PendingYarn(anchor, y.kind, y.index, tuple(y.plane), 0.0, y.k, index,
                                   ij=tuple(r.mesh.ij[anchor]), point=y.point)
        self.update()

    def set_choice(self, kind: str | None = None, angle_deg: float | None = None, k: float | None = None) -> None:
        p = self.pending
        if p is None:
            return
        if kind is not None and kind != p.kind and p.replaces is None:
            p.kind, p.index = kind, yarn_index(self.result.mesh, p.node, kind)
        if angle_deg is not None:
            p.angle_deg = float(angle_deg)
        if k is not None:
            p.k = float(k)
        self.update()

    def nodes(self) -> np.ndarray:
        p = self.pending
        return np.zeros(0, dtype=np.int64) if p is None else yarn_nodes(self.result.mesh, p.kind, p.index)

    def update(self) -> None:
        """Recompute the plane and the highlight for the current choices."""
        p, r = self.pending, self.result
        if p is None or r is None:
            return
        nodes = yarn_nodes(r.mesh, p.kind, p.index)
        self.draw("picked yarn", [r.xyz[nodes]], r.xyz[p.node], render=False)
        normal = self.surface.evaluate(r.uv[p.node:p.node + 1]).normal[0]
        self.plane = None
        try:
            if len(nodes) < 2:
                raise SettingsError(f"{p.kind} {p.index} has a single node: no direction to hold")
            base = p.base if p.base is not None else yarn_plane(r.xyz[nodes[[0, -1]]], normal)
            self.plane = turn_plane(base, r.xyz[p.node], normal, p.angle_deg)
            uv = PlaneDart(self.plane).curve_uv(self.surface, PREVIEW_GRID)
            self.draw_preview(self.surface.points(uv) if len(uv) >= 2 else None)
        except SettingsError as exc:
            self.draw_preview()
            self.hint(str(exc))
        self.show_editor()

    def finish(self) -> bool:
        p = self.pending
        if p is None or self.plane is None:
            self.hint("Pick a node first." if p is None else "This yarn has no plane to hold it to.")
            return False
        try:
            yarn = YarnConstraint(p.kind, p.index, self.plane, p.k, point=p.point)
        except SettingsError as exc:
            self.hint(str(exc))
            return False
        if p.replaces is None:
            self.document.add_yarn(yarn)
        else:
            self.document.replace_yarn(p.replaces, yarn)
        self.pending = None
        self.draw("picked yarn")
        self.draw_preview()
        self.hide_editor()
        self.hint(f"Constrained the {yarn.label()}. Click another node, or Esc.")
        return True

    def cancel(self) -> None:
        if self.pending is not None:
            self.pending = None
            self.draw("picked yarn")
            self.draw_preview()
            self.hide_editor()
        else:
            self.host.drop_tool()


# ---------------------------------------------------------------------- regions
INSERT_PIXELS = 8  # a double click this close to a side of the drawn region inserts a point there


def _segment_nearest(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(t, distance), (k,) each: the point a[i] + t (b[i] - a[i]) of each segment a[i]-b[i] ((k, 2) each)
    nearest to 2D point ``p``, and its distance from ``p``."""
    d = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-300), 0.0, 1.0)
    return t, np.linalg.norm(a + t[:, None] * d - p, axis=1)


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(k,) distance of 2D point ``p`` from segments a[i]-b[i] ((k, 2) each)."""
    return _segment_nearest(p, a, b)[1]


class RegionTool(PointsTool):
    """Draw and edit the piece's region (a ply boundary) on the surface.

    Drawing: clicks add points (each under the cursor; near the face's edge
    they snap onto it), the loop between them follows the surface as a curve
    dart's curve does (:func:`flatweave.geometry.region.region_from_spec`, projected along
    the view); Enter or a click on the first point closes it, Esc cancels,
    Backspace takes back a point. A loop drawn inside a drawn region is a hole
    of it; elsewhere it is a new region.

    Editing the drawn region (its points are handles): drag one (the piece
    re-solves as it moves, a preview outside the document through
    ``host.preview_settings``, the newest position winning; the release is
    one edit the preview answers), double-click a side to insert a point
    there, double-click a point (or pick it and press Delete or Backspace) to
    delete it; deleting a point of a three-point hole deletes the hole.
    Every commit is one settings edit (the region and its seed: the old seed
    while it stays inside, else the farthest-from-the-edge point), so undo,
    redo, re-runs and saving work as for any other edit."""

    name = "region"
    what = "region"

    def __init__(self, host):
        super().__init__(host)
        self.preview = None                  # flatweave.geometry.region.Region of the loop so far
        self.grabbed: tuple[int, int] | None = None  # (loop, point) of the drawn region being dragged
        self.picked: tuple[int, int] | None = None   # the last point grabbed (Delete removes it)
        self.dragged: dict | None = None     # the drawing with the dragged point moved
        self.previewing = False              # a preview of an uncommitted position was asked for

    @property
    def points(self) -> list[np.ndarray]:
        """xyz of the points placed (on the surface) of a loop being drawn."""
        return self.placed

    def activate(self) -> None:
        self.hint("Region: click points round the piece on the surface; Enter or a click on the first point "
                  "closes it, Esc cancels, Backspace takes back a point. A loop inside the region is a hole. "
                  "Drag a drawn point to move it, double-click a side to insert one, double-click a point "
                  "(or pick it and press Delete) to delete it.")
        self._show_handles()

    def deactivate(self) -> None:
        self.cancel(quiet=True)
        self.draw_handles()
        self._end_preview()

    def on_result(self) -> None:
        if not self.placed and self.grabbed is None:
            self._show_handles()  # undo or redo may have changed the region

    # -- the drawn region's points
    def _drawing(self):
        region = self.document.project.settings.region
        drawn = region.drawn if region is not None else None
        return drawn if drawn is not None and drawn.form == "points" else None

    def _drawn_loops(self) -> list[np.ndarray]:
        drawn = self._drawing()
        if drawn is None:
            return []
        return [np.array(drawn.outer)] + [np.array(h) for h in drawn.holes]

    def _show_handles(self) -> None:
        loops = self._drawn_loops()
        self.draw_handles(np.vstack(loops) if loops else None)

    def _handle_at(self, x, y) -> tuple[int, int] | None:
        """(loop, point) of the drawn region's point within HANDLE_PIXELS of (x, y), or None."""
        loops = self._drawn_loops()
        if not loops:
            return None
        disp = self.view.display_points(np.vstack(loops))
        dist = np.hypot(disp[:, 0] - x, disp[:, 1] - y)
        j = int(np.argmin(dist))
        if dist[j] > HANDLE_PIXELS:
            return None
        ends = np.cumsum([len(p) for p in loops])
        k = int(np.searchsorted(ends, j, side="right"))
        return k, j - (int(ends[k - 1]) if k else 0)

    def _side_at(self, x, y) -> tuple[int, int] | None:
        """(loop, i) of the side from drawn point i to i + 1 within INSERT_PIXELS of (x, y) on
        screen, or None. A side is drawn as the straight segment between its points' pixels:
        exact in the view it was drawn in (the projection of a segment along the view), close
        to the curve in a view turned a little from it."""
        best = None
        for k, loop in enumerate(self._drawn_loops()):
            d = self.view.display_points(loop)
            dist = _segment_distance(np.array([x, y], float), d, np.roll(d, -1, axis=0))
            i = int(np.argmin(dist))
            if dist[i] <= INSERT_PIXELS and (best is None or dist[i] < best[0]):
                best = (float(dist[i]), k, i)
        return None if best is None else (best[1], best[2])

    def _spec_with(self, change) -> dict:
        """The drawn region's spec with ``change(loops)`` applied to its list of loops (outer first),
        seen along this view (the points are on the surface and seen in it)."""
        spec = self._drawing().to_dict()
        loops = [spec["points"]] + spec.get("holes", [])
        change(loops)
        spec["points"] = loops[0]
        if len(loops) > 1:
            spec["holes"] = loops[1:]
        else:
            spec.pop("holes", None)
        spec["view_direction"] = [float(v) for v in self.view.view_direction()]
        return spec

    def _edit_of(self, spec) -> tuple:
        """(region, seed) the spec makes, checked as every commit is (SettingsError otherwise):
        the same for a drag's preview and its release, so the release adopts the preview."""

        s = self.document.project.settings
        region = region_from_spec(self.surface, spec)
        check_region_size(self.surface, region, s.spacing, s.spacing_warp)
        cover = cover_for(self.surface, region)
        seed = s.seed if cover.contains(cover.seed_uv(s.seed)[None])[0] else cover.default_seed
        return region, seed

    def _commit(self, spec, label: str) -> bool:
        try:
            region, seed = self._edit_of(spec)
            edit = self.document.edit_settings(label, region=region, seed=seed)
        except SettingsError as exc:
            self.hint(f"Cannot {label.lower()}: {exc}")
            self._show_handles()
            return False
        if edit is None and self.previewing:
            self.host.end_preview()  # nothing changed: no edit, nothing to answer
        self.previewing = False  # the edit takes the preview over (or re-runs)
        self.hint(f"{label}: the region has {len(region.drawn.outer)} points and {region.n_holes} hole(s).")
        self._show_handles()
        return True

    def _end_preview(self) -> None:
        if self.previewing:
            self.previewing = False
            self.host.end_preview()

    def _delete_point(self, at: tuple[int, int]) -> bool:
        k, i = at
        loops = self._drawn_loops()
        if len(loops[k]) <= 3 and k == 0:
            self.hint("The region's outer loop needs at least three points: none deleted "
                      "(Esc, or draw a new region).")
            return False
        self.picked = None

        def change(ls):
            if len(ls[k]) <= 3:
                del ls[k]  # a hole of three points: the hole goes
            else:
                del ls[k][i]
        label = "Delete hole" if k and len(loops[k]) <= 3 else "Delete region point"
        return self._commit(self._spec_with(change), label)

    def _insert_point(self, side: tuple[int, int], x, y) -> bool:
        hit = pick_surface(self.surface, self.view, x, y)
        if hit is None:
            self.hint("That double click missed the surface: no point inserted.")
            return False
        k, i = side
        self.picked = (k, i + 1)
        return self._commit(self._spec_with(lambda ls: ls[k].insert(i + 1, [float(c) for c in hit[1]])),
                            "Insert region point")

    # -- events
    def move(self, x, y):
        if self.grabbed is None:
            return False
        hit = pick_surface(self.surface, self.view, x, y)
        if hit is None:
            return True  # off the surface: the point stays where it was
        k, i = self.grabbed

        def change(ls):
            ls[k][i] = [float(c) for c in hit[1]]
        self.dragged = self._spec_with(change)
        pts = np.vstack([self.dragged["points"]] + self.dragged.get("holes", []))
        curve = None
        try:
            region, seed = self._edit_of(self.dragged)
        except SettingsError as exc:
            self.hint(str(exc))
        else:
            loop = np.asarray(region.loops[min(k, region.n_holes)])
            curve = self.surface.points(np.vstack([loop, loop[:1]]))
            self.previewing = True
            self.host.preview_settings(region=region, seed=seed)
        self.draw_handles(pts, render=False)
        self.draw_preview(curve, None)
        return True

    def release(self, x, y):
        if self.grabbed is None:
            return False
        spec, self.grabbed, self.dragged = self.dragged, None, None
        self.draw_preview()
        if spec is None:
            return True  # a click on a point: picked (Delete removes it)
        if not self._commit(spec, "Move region point"):
            self._end_preview()
        return True

    def press(self, x, y, double):
        if double and len(self.placed) == 1 and self._same_as_last(x, y):
            side = self._side_at(x, y)
            if side is not None:  # the first click of this double click began a loop: it was an insert
                self._clear()
                self._insert_point(side, x, y)
                return True
        if not self.placed:
            at = self._handle_at(x, y)
            if at is None and double and self._side_at(x, y) is not None:
                self._insert_point(self._side_at(x, y), x, y)
                return True
            if at is not None:
                if double:
                    self._delete_point(at)
                    return True
                self.grabbed, self.picked, self.dragged = at, at, None
                self.hint(f"Picked point {at[1] + 1} of the region's {'outer loop' if at[0] == 0 else 'hole'}: "
                          "drag it, or Delete removes it.")
                return True
        if len(self.pixels) >= 3 and math.hypot(x - self.pixels[0][0], y - self.pixels[0][1]) <= HANDLE_PIXELS:
            self.finish()
            return True
        if self._same_as_last(x, y):
            if double and len(self.placed) >= 3:
                self.finish()
            return True
        hit = self._hit(x, y)
        if hit is None:
            self.hint("That click missed the surface: no point added. Click on the surface (Esc cancels).")
            return False
        self.picked = None
        self._place(hit[1], x, y)
        n = len(self.placed)
        where = "on the edge" if hit[2] else "on the surface"
        self.hint(f"Point {n} {where}. " + ("Click the next point." if n < 3 else
                                            "Click more points; Enter or the first point closes the loop."))
        if double and n >= 3:
            self.finish()
        return True

    def back(self) -> None:
        if self.placed:
            super().back()
        elif self.picked is not None and self.grabbed is None:
            self._delete_point(self.picked)

    # -- a new loop
    def _spec(self) -> dict:
        """The region the points make: a hole of the drawn region when they lie inside it."""

        view = [float(v) for v in self.view.view_direction()]
        loop = [p.tolist() for p in self.placed]
        region = self.document.project.settings.region
        drawn = self._drawing()
        if drawn is not None:
            uv = project_points(self.surface, np.array(self.placed), np.array(drawn.view_direction)).uv
            if np.isfinite(uv).all() and cover_for(self.surface, region).contains(uv).all():
                spec = drawn.to_dict()
                spec["holes"] = spec.get("holes", []) + [loop]
                return spec
        return {"points": loop, "view_direction": view}

    def _update_preview(self) -> None:
        pts = np.array(self.placed) if self.placed else None
        self.preview = None
        curve = pts
        if len(self.placed) >= 3:
            try:
                spec = self._spec()
                self.preview = region_from_spec(self.surface, spec)
                k = len(self.preview.loops) - 1 if "holes" in spec else 0
                loop = np.asarray(self.preview.loops[k])
                curve = self.surface.points(np.vstack([loop, loop[:1]]))
            except SettingsError as exc:
                self.hint(str(exc))
        self.draw_preview(curve, pts)

    def finish(self) -> bool:
        if len(self.placed) < 3:
            self.hint("A region needs at least three points on the surface.")
            return False
        doc = self.document
        s = doc.project.settings
        try:
            spec = self._spec()
            region = region_from_spec(self.surface, spec)
            check_region_size(self.surface, region, s.spacing, s.spacing_warp)
        except SettingsError as exc:
            self.hint(f"Cannot make the region: {exc}")
            return False
        label = "Draw hole" if "holes" in spec and len(region.loops) > 1 and s.region is not None \
            and len(region.loops) > len(s.region.loops) else "Draw region"
        self._clear()
        try:
            doc.edit_settings(label, region=region, seed=cover_for(self.surface, region).default_seed)
        except SettingsError as exc:
            self.hint(f"Cannot make the region: {exc}")
            return False
        self.hint(f"{label}: {len(region.loops) - 1} hole(s).")
        self._show_handles()
        return True


# ---------------------------------------------------------------------- the seed and the rosette
ROSETTE_FRACTION = 0.12  # the weft arrow's length, of the surface's size


class SeedTool(Tool):
    """Pick the drape's seed and weft direction (the rosette) on the surface: a
    click inside the piece puts the seed there, a drag from it turns the weft
    towards the cursor (measured in the seed's tangent plane). The rosette is
    drawn as two arrows, weft and warp. A click outside the piece's region is
    refused with a one-line hint and changes nothing. The release is one
    settings edit (seed, and angle when dragged)."""

    name = "seed"
    layers = {"weft arrow": LayerStyle("#c0392b", width=4.0), "warp arrow": LayerStyle("#1f5fbf", width=4.0)}

    def __init__(self, host):
        super().__init__(host)
        self.seed: tuple[float, float] | None = None   # the seed being placed (fractions of the domain)
        self.angle: float | None = None
        self.start: tuple[float, float] | None = None  # the press's pixel

    def activate(self) -> None:
        self.hint("Seed: click inside the piece to put the seed there; drag from it to turn the weft "
                  "(the red arrow; blue is the warp). Drag off the surface to turn the view.")
        self._draw()

    def deactivate(self) -> None:
        self.seed = self.angle = self.start = None
        self.clear_drawing()

    def on_result(self) -> None:
        if self.seed is None:
            self._draw()

    def _length(self) -> float:
        xyz = _rim(self.surface)[1]  # the surface's size: the diagonal of its rim's box
        return ROSETTE_FRACTION * float(np.linalg.norm(np.ptp(xyz, axis=0)))

    def _draw(self, seed=None, angle=None) -> None:
        s = self.document.project.settings
        r = rosette(self.surface, s.seed if seed is None else seed, s.angle_deg if angle is None else angle)
        weft, warp = rosette_arrows(r, self._length())
        self.draw("weft arrow", [weft], render=False)
        self.draw("warp arrow", [warp])

    def press(self, x, y, double):
        hit = pick_surface(self.surface, self.view, x, y)
        if hit is None:
            return False
        region = self.document.project.settings.region
        if region is not None and not cover_for(self.surface, region).contains(np.asarray(hit[0])[None])[0]:
            self.hint("That point lies outside the piece's region: the seed must be inside it (nothing changed).")
            return True
        self.seed, self.angle, self.start = seed_fraction(self.surface, hit[0]), None, (float(x), float(y))
        self._draw(self.seed)
        return True

    def move(self, x, y):
        if self.seed is None:
            return False
        if math.hypot(x - self.start[0], y - self.start[1]) < STROKE_PIXELS:
            return True  # a click, not yet a drag
        hit = pick_surface(self.surface, self.view, x, y)
        if hit is None:
            return True
        angle = angle_towards(self.surface, self.seed, hit[1])
        if angle is not None:
            self.angle = round(angle, 1)  # as the settings panel shows it
            self._draw(self.seed, self.angle)
            self.hint(f"Weft at {self.angle:g} deg from the u direction; release to keep it.")
        return True

    def release(self, x, y):
        if self.seed is None:
            return False
        seed, angle, self.seed, self.angle, self.start = self.seed, self.angle, None, None, None
        changes = {"seed": seed} if angle is None else {"seed": seed, "angle_deg": angle}
        label = "Move seed" if angle is None else "Seed and weft direction"
        try:
            self.document.edit_settings(label, **changes)
        except SettingsError as exc:
            self.hint(f"Cannot move the seed: {exc}")
        else:
            self.hint(f"{label}: seed at ({seed[0]:.3f}, {seed[1]:.3f})"
                      + ("." if angle is None else f", weft at {angle:g} deg."))
        self._draw()
        return True
