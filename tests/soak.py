"""Soak test: a thousand random edits through the window's command layer.

Not part of the default test run (pytest collects ``test_*.py`` only). Run it
on a display, e.g.::

    xvfb-run -a -s '-screen 0 1600x1000x24' .venv/bin/python tests/soak.py [--edits 1000] [--seed 1] [--view canvas]

It opens the octant example in a real MainWindow and makes random edits the
way the GUI makes them (``MainWindow.edit_settings`` / ``edit_display`` /
``dart_edit`` over the document's dart and yarn edits / ``delete_dart`` /
``undo`` / ``redo`` / ``run`` / ``rerun`` / ``stop`` / ``toggle_pause`` /
``save_to`` / ``open_file`` / ``autosave``): darts added, edited and removed,
settings and display changed, runs started, paused and stopped at random
moments, projects saved and reopened. It also opens other documents: the
bundled examples, CAD faces (STEP and IGES files written with Open CASCADE by
tests/cadfiles.py: one trimmed face with its region, files of several faces
chosen or joined in the face picker) and meshes made with trimesh at sizes far
from the examples' metre (a bumpy sheet of hundreds of units, a cap a few
thousandths across, a closed mesh whose piece is drawn in the mesh picker); it
draws regions and curve darts with real clicks through the tools, asks for
suggested darts and a best orientation (previewed, applied or closed), exports
the pattern, changes the view options, and zooms, turns and resets the 3D
view's camera. Between edits the event loop runs for a random 0-300 ms, so
edits land mid-run as a designer's would. The dimensions of darts, yarn planes
and spacings follow the open surface's size.

After every edit it asserts the document is consistent
(``flatweave.document.project.project_problems``; a result marked current was made with the
current settings; the undo stack within its limit; at most one solve thread
alive; Run enabled exactly when idle), that both views draw what the document
holds (:meth:`Soak.view_problems`: the surface actor in the 3D view's
renderer, visible as the options say, holding this document's surface; a
result's mesh drawn in both views and its outline in the pattern; the views'
images not blank: a share of the pixels outside the colour bars and the axes
differ from the background; the camera sees the surface: some of its points
inside the view's frustum and none of those cut off by the clipping range)
and records the process's resident memory. A failed check is reported with
the seed and the edits that led to it (``--log``), and ``--stop-on-blank``
ends the run there, keeping the view's image. At the end it fits a line to
the memory of the second half of the edits and fails if it grows by more than
``--max-growth`` MB per 100 edits. It prints a table and writes it to
``benchmarks/results/soak.md``; exit status 0 when every check held.
"""

from __future__ import annotations

import argparse
import gc
import os
import platform
import random
import sys
import tempfile
import threading
import time
import traceback
from collections import Counter
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def rss_mb() -> float:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


# ---------------------------------------------------------------------- the files it opens
def _grid_triangles(n: int, m: int) -> np.ndarray:
    idx = np.arange(n * m).reshape(n, m)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    return np.r_[np.stack([a, b, c], 1), np.stack([a, c, d], 1)]


def _write_stl(path: Path, V, F) -> Path:
    import trimesh
    path.write_bytes(trimesh.Trimesh(np.asarray(V, float), np.asarray(F), process=False).export(file_type="stl"))
    return path


def make_inputs(folder: Path) -> dict[str, list[Path]]:
    """The files the soak opens besides the examples, by kind: ``mesh`` (open
    meshes: a bumpy sheet 400 x 300 units, a sphere cap 0.0024 across),
    ``closed mesh`` (a closed 'hand', 180 units long: its piece is drawn in the
    mesh picker), ``cad face`` (one trimmed face, with its region: STEP and
    IGES in mm, STEP in metres) and ``cad faces`` (several faces: the face
    picker). CAD files only with Open CASCADE."""
    data = Path(__file__).parent / "data"
    files: dict[str, list[Path]] = {"mesh": [], "closed mesh": [], "cad face": [], "cad faces": [],
                                    "hostile": sorted([*(data / "bad").iterdir(), *(data / "hostile").glob("*.json")])}
    try:
        import trimesh
    except ImportError:
        trimesh = None
    if trimesh is not None:
        n, m = 32, 26
        x, y = np.meshgrid(np.linspace(0, 400, n), np.linspace(0, 300, m), indexing="ij")
        z = 25 * np.sin(x / 400 * 2 * np.pi) * np.cos(y / 300 * np.pi) + 8 * np.sin(x / 45) * np.sin(y / 50)
        files["mesh"].append(_write_stl(folder / "sheet_mm.stl", np.c_[x.ravel(), y.ravel(), z.ravel()],
                                        _grid_triangles(n, m)))
        k = 24
        u, v = np.meshgrid(np.linspace(-0.6, 0.6, k), np.linspace(-0.6, 0.6, k), indexing="ij")
        F = _grid_triangles(k, k)
        cx, cy = u.ravel(), v.ravel()
        F = F[np.hypot(cx[F].mean(1), cy[F].mean(1)) < 0.6]
        used = np.unique(F)
        cx, cy = cx[used], cy[used]
        V = 0.002 * np.c_[cx, cy, np.sqrt(1 - cx * cx - cy * cy)]  # a cap of a sphere of radius 2 mm, in metres
        files["mesh"].append(_write_stl(folder / "cap_tiny.stl", V, np.searchsorted(used, F)))
        ball = trimesh.creation.icosphere(3)
        V = ball.vertices * [90.0, 45.0, 20.0]
        V[:, 2] += 4.0 * np.sin(V[:, 0] / 15.0)  # knuckles
        files["closed mesh"].append(_write_stl(folder / "hand.stl", V, ball.faces))
    try:
        from tests import cadfiles as cf
        from tests.test_faces_join import fillet_shell
    except ImportError:  # no Open CASCADE: no CAD files
        return files
    from OCP.gp import gp_Trsf, gp_Vec
    from OCP.TopLoc import TopLoc_Location

    def moved(shape, dx):
        t = gp_Trsf()
        t.SetTranslation(gp_Vec(dx, 0.0, 0.0))
        return shape.Moved(TopLoc_Location(t))

    files["cad face"] += [cf.write_step(cf.face_circle_hole(), folder / "face_hole.step"),
                          cf.write_iges(cf.face_free_outer(), folder / "face_free.igs"),
                          cf.write_step(cf.face_rational_hole(), folder / "face_rational_m.step", unit="M")]
    files["cad faces"] += [cf.write_step(cf.compound(cf.face_circle_hole(), moved(cf.face_mixed_outer(), 70.0),
                                                     moved(cf.face_rational_hole(), 140.0)), folder / "three.step"),
                           cf.write_step(fillet_shell(), folder / "fillet.step")]
    return files


# ---------------------------------------------------------------------- what the views show
def view_image(view) -> np.ndarray:
    """(h, w, 3) uint8: the view's pixels, top row first. The canvas: what it
    painted last (what is on screen); the OpenGL widget: its framebuffer
    rendered now (``grabFramebuffer``)."""
    from flatweave.app.canvas import CanvasPlotter
    from PySide6.QtGui import QImage

    if isinstance(view.plotter, CanvasPlotter):
        return view.widget.image()
    q = view.widget.grabFramebuffer()
    if q.isNull():  # no framebuffer to read (no GL context): nothing drawn
        return np.zeros((1, 1, 3), dtype=np.uint8)
    q = q.convertToFormat(QImage.Format.Format_RGB888)
    rows = np.frombuffer(q.constBits(), np.uint8).reshape(q.height(), q.bytesPerLine())
    return rows[:, :3 * q.width()].reshape(q.height(), q.width(), 3).copy()


def widget_state(view) -> str:
    """What a blank view's widget says of itself: its size and visibility, and
    for the OpenGL widget its context and the share of its pixels on the screen
    (the X server's own copy of the window) that differ from the background."""
    from flatweave.app.canvas import CanvasPlotter
    from PySide6.QtGui import QGuiApplication, QImage

    w = view.widget
    text = f"widget {w.width()}x{w.height()}, visible {w.isVisible()}"
    if w.width() < 32 or w.height() < 32:  # the layout gave it no room: name the widest label
        from PySide6.QtWidgets import QLabel
        labels = [c for c in w.window().findChildren(QLabel) if c.isVisible()]
        if labels:
            widest = max(labels, key=lambda c: c.minimumSizeHint().width())
            text += (f" (squeezed out by the layout; the widest label asks {widest.minimumSizeHint().width()} px: "
                     f"{widest.text()[:80]!r})")
    if isinstance(view.plotter, CanvasPlotter):
        return text + f", painted {w.renders} times"
    rw = view.plotter.render_window
    text += (f", GL valid {w.isValid()}, context {'yes' if w.context() is not None else 'none'}, "
             f"ready {bool(rw is not None and rw.GetReadyForRendering())}")
    top = w.mapTo(w.window(), w.rect().topLeft())
    grab = QGuiApplication.primaryScreen().grabWindow(w.window().winId(), top.x(), top.y(), w.width(), w.height())
    q = grab.toImage().convertToFormat(QImage.Format.Format_RGB888)
    if not q.isNull():
        rows = np.frombuffer(q.constBits(), np.uint8).reshape(q.height(), q.bytesPerLine())
        screen = rows[:, :3 * q.width()].reshape(q.height(), q.width(), 3)
        text += f", {drawn_share(view, screen):.4f} of its pixels on the screen drawn"
    return text


def drawn_share(view, image: np.ndarray, overlays=()) -> float:
    """The share of the view's pixels that differ from the background, over
    the view less ``overlays`` ((x0, y0, x1, y1) as fractions of the width and
    height, y down: colour bars, the axes), which are drawn whatever the scene holds."""
    from flatweave.app.viewbase import BACKGROUND

    h, w = image.shape[:2]
    bg = np.array([int(BACKGROUND[i:i + 2], 16) for i in (1, 3, 5)])
    mask = np.ones((h, w), dtype=bool)
    for x0, y0, x1, y1 in overlays:
        mask[int(y0 * h):int(np.ceil(y1 * h)), int(x0 * w):int(np.ceil(x1 * w))] = False
    differs = np.abs(image.astype(int) - bg).max(axis=2) > 8
    return float(differs[mask].mean()) if mask.any() else 0.0


def frustum(view, points: np.ndarray) -> tuple[int, int, int]:
    """(points in front of the camera inside the view's rectangle, of those
    the ones the clipping range cuts off, points) for world points (k, 3),
    through the renderer's own camera transform."""
    ren = view.plotter.renderer
    cam = ren.GetActiveCamera()
    m = cam.GetCompositeProjectionTransformMatrix(ren.GetTiledAspectRatio(), -1, 1)
    M = np.array([[m.GetElement(i, j) for j in range(4)] for i in range(4)])
    P = np.c_[np.asarray(points, float).reshape(-1, 3), np.ones(len(points))] @ M.T
    front = P[:, 3] > 0
    ndc = P[:, :3] / np.where(front, P[:, 3], 1.0)[:, None]
    inside = front & (np.abs(ndc[:, 0]) <= 1) & (np.abs(ndc[:, 1]) <= 1)
    cut = inside & (np.abs(ndc[:, 2]) > 1 + 1e-9)
    return int(inside.sum()), int(cut.sum()), len(P)


def stray_props(view, points) -> list[str]:
    """The visible props of a view whose bounds reach beyond ``points``' box
    grown by a tenth of its size (they set the clipping range too), each named
    by the view's attribute that holds it when there is one."""
    names = {}
    for owner, prefix in ((view, ""), (view.layer, "layer.")):
        for attr, value in vars(owner).items():
            for item in (value if isinstance(value, (list, tuple)) else [value]):
                for obj in (item if isinstance(item, tuple) else (item,)):
                    if hasattr(obj, "GetBounds") and hasattr(obj, "GetVisibility"):
                        names[obj.GetAddressAsString("vtkProp")] = prefix + attr
    lo, hi = np.min(points, axis=0), np.max(points, axis=0)
    pad = 0.1 * float(np.max(hi - lo)) + 1e-300
    out = []
    props = view.plotter.renderer.GetViewProps()
    props.InitTraversal()
    for _ in range(props.GetNumberOfItems()):
        prop = props.GetNextProp()
        b = prop.GetBounds() if prop.GetVisibility() and prop.GetUseBounds() else None
        if b is None or b[0] > b[1]:
            continue
        b = np.asarray(b).reshape(3, 2)
        if (b[:, 0] < lo - pad).any() or (b[:, 1] > hi + pad).any():
            name = names.get(prop.GetAddressAsString("vtkProp"), prop.GetClassName())
            out.append(f"{name} {np.round(b.ravel(), 4).tolist()}")
    return out


class Soak:
    def __init__(self, win, rng: random.Random, folder: Path, inputs: dict[str, list[Path]] | None = None):
        self.win = win
        self.rng = rng
        self.folder = folder
        self.inputs = inputs or {}
        self.counts: Counter = Counter()
        self.errors: Counter = Counter()
        self.max_threads = 0
        self.saved: Path | None = None
        self.outcomes: Counter = Counter()
        self.with_result = 0
        self.log: list[str] = []  # every edit made, with what it was made with (a failure's history)
        self.view_checks = 0
        self.shares: dict[str, list[float]] = {"3D view": [], "pattern view": []}  # drawn shares seen
        self.seconds: Counter = Counter()  # time spent per kind of edit
        self._base_spacing: dict[int, float] = {}  # each surface's spacing when first seen
        self._extent_of: tuple | None = None
        self._grid_of: tuple | None = None
        self._moved = 0.0  # wheel steps the soak has zoomed the camera since the last framing
        self._turned = 0.0  # pixels it has dragged the camera round since then
        self.export_failures: list[str] = []
        win.run_finished.connect(self._finished)
        win.export_failed.connect(lambda m: self.export_failures.append(f"edit {len(self.log)}: {m}"))
        self.run_failures: list[str] = []
        win.run_failed.connect(self._failed)

    def _failed(self, message: str) -> None:
        self.outcomes["failed"] += 1
        self.run_failures.append(f"edit {len(self.log)}: {message}")

    def _finished(self, outcome) -> None:
        if outcome.result is None:
            self.outcomes["stopped before a result"] += 1
        else:
            self.outcomes["stopped" if outcome.stopped else "converged or on a budget"] += 1

    # ------------------------------------------------------------------ helpers
    @property
    def doc(self):
        return self.win.document

    def pump(self, ms: float) -> None:
        from PySide6.QtWidgets import QApplication
        end = time.perf_counter() + ms / 1000.0
        while True:
            QApplication.processEvents()
            if time.perf_counter() >= end:
                return
            time.sleep(0.005)

    def wait(self, busy, timeout: float = 300.0) -> bool:
        """Run the event loop while ``busy()`` (at most ``timeout`` s); True if it ended."""
        end = time.perf_counter() + timeout
        while busy() and time.perf_counter() < end:
            self.pump(20)
        return not busy()

    def extent(self) -> tuple[np.ndarray, np.ndarray, float]:
        """(lo, hi, size) of the open surface: its bounding box and diagonal (cached per surface)."""
        surface = self.doc.project.surface
        if self._extent_of is None or self._extent_of[0] is not surface:
            (u0, u1), (v0, v1) = surface.domain
            u, v = np.meshgrid(np.linspace(u0, u1, 9), np.linspace(v0, v1, 9), indexing="ij")
            pts = surface.points(np.c_[u.ravel(), v.ravel()])
            lo, hi = pts.min(axis=0), pts.max(axis=0)
            self._extent_of = (surface, lo, hi, float(np.linalg.norm(hi - lo)))
        return self._extent_of[1:]

    def uv_at(self, fu: float, fv: float) -> np.ndarray:
        """The parameter point at fractions (fu, fv) of the open surface's domain."""
        (u0, u1), (v0, v1) = self.doc.project.surface.domain
        return np.array([u0 + fu * (u1 - u0), v0 + fv * (v1 - v0)])

    def base_spacing(self) -> float:
        p = self.doc.project
        return self._base_spacing.setdefault(id(p.surface), p.settings.spacing)

    def click(self, view, xy, double: bool = False) -> None:
        """A real left click on a view at display pixel ``xy`` (VTK's, origin bottom left)."""
        from PySide6.QtCore import QPoint, Qt
        from PySide6.QtTest import QTest

        w = view.widget
        pos = QPoint(int(round(xy[0])), w.height() - 1 - int(round(xy[1])))
        (QTest.mouseDClick if double else QTest.mouseClick)(w, Qt.MouseButton.LeftButton,
                                                             Qt.KeyboardModifier.NoModifier, pos)

    def on_screen(self, view, xyz) -> list[tuple[float, float]]:
        """Display pixels of world points that fall inside the view (the others dropped)."""
        w, h = view.device_size()
        out = []
        for p in np.asarray(xyz, float).reshape(-1, 3):
            x, y = view.display_point(p)
            if 5 <= x < w * (1 - view.bar_column_fraction()) - 5 and 5 <= y < h - 5:
                out.append((x, y))
        return out

    def settle(self, timeout: float = 120.0) -> None:
        """Let any run finish (or stop it after ``timeout``)."""
        end = time.perf_counter() + timeout
        while self.win.runner.busy and time.perf_counter() < end:
            self.pump(20)
        if self.win.runner.busy:
            self.win.stop()
            while self.win.runner.busy:
                self.pump(20)

    # ------------------------------------------------------------------ the edits
    KINDS = ["curve dart", "plane dart", "remove dart", "rename dart", "hide dart", "yarn", "remove yarn",
             "spacing", "material", "angle", "tolerance", "solver", "units", "shear angles", "run",
             "rerun", "stop", "pause", "undo", "undo", "redo", "save", "open", "autosave",
             # other documents, the tools, the dialogs, the view
             "example", "cad face", "cad faces", "mesh", "mesh", "closed mesh", "region", "region", "curve tool",
             "suggest", "sweep", "export", "view", "view", "zoom", "zoom", "turn", "reset view", "hostile"]

    def edit(self) -> str:
        kind = self.rng.choice(self.KINDS)
        t0 = time.perf_counter()
        what = self._edit(kind)
        self.seconds[kind] += time.perf_counter() - t0
        if what is None:
            kind = f"{kind} (nothing to do)"
        self.counts[kind] += 1
        self.log.append(kind if not what else f"{kind}: {what}")
        return kind

    def _edit(self, kind: str) -> str | None:
        """Make one edit of ``kind``; what it was made with ("" if nothing to say), None if there was nothing to do."""
        from flatweave.method.darts import CurveDart, PlaneDart
        from flatweave.method.energy import YarnConstraint
        from flatweave.method.lattice import MATERIALS

        win, rng, doc = self.win, self.rng, self.doc
        darts = doc.project.settings.darts
        lo, hi, _size = self.extent()
        if kind == "curve dart":
            f0 = rng.uniform(0.2, 0.8)
            depth = rng.uniform(0.2, 0.5)
            bend = rng.uniform(-0.1, 0.1)
            t = np.linspace(0.0, 1.0, 6)
            uv = np.array([self.uv_at(depth * s, f0 + bend * s ** 2) for s in t])
            win.dart_edit(doc.add_dart, CurveDart(uv, name=f"curve {self.counts[kind]}"))
            return f"from {uv[0].round(4).tolist()} to {uv[-1].round(4).tolist()}"
        if kind == "plane dart":
            axis = rng.randrange(3)
            c = lo[axis] + rng.uniform(0.3, 0.7) * (hi[axis] - lo[axis])
            normal = [0.0, 0.0, 0.0]
            normal[axis] = 1.0
            pad = 0.1 * (hi - lo) + 1e-9
            box = [float(x) for pair in zip(lo - pad, hi + pad) for x in pair]
            other = (axis + 1) % 3
            box[2 * other + 1] = float(lo[other] + rng.uniform(0.3, 0.7) * (hi[other] - lo[other]))  # a tip inside
            win.dart_edit(doc.add_dart, PlaneDart((*normal, -c), tuple(box), name=f"plane {self.counts[kind]}"))
            return f"axis {axis} at {c:.5g}"
        if kind == "remove dart" and darts:
            i = rng.randrange(len(darts))
            win.delete_dart(i)
            return f"{i}"
        if kind == "rename dart" and darts:
            win.dart_edit(doc.rename_dart, rng.randrange(len(darts)), f"renamed {rng.randrange(1000)}")
            return ""
        if kind == "hide dart" and darts:
            i = rng.randrange(len(darts))
            win.dart_edit(doc.set_dart_visible, i, not darts[i].visible)
            return f"{i}"
        if kind == "yarn":
            z = lo[2] + rng.uniform(0.2, 0.6) * (hi[2] - lo[2])
            win.dart_edit(doc.add_yarn, YarnConstraint(rng.choice(["weft", "warp"]), rng.randrange(-2, 3),
                                                        (0.0, 0.0, 1.0, -z), rng.choice([10.0, 100.0])))
            return f"z {z:.5g}"
        if kind == "remove yarn" and doc.project.settings.yarns:
            win.dart_edit(doc.remove_yarn, rng.randrange(len(doc.project.settings.yarns)))
            return ""
        if kind == "spacing":
            s = self.base_spacing() * rng.choice([0.75, 0.83, 0.92, 1.0, 1.17])
            win.edit_settings("Spacing", {"spacing": s, "spacing_warp": s})
            return f"{s:.5g}"
        if kind == "material":
            name = rng.choice(sorted(MATERIALS))
            win.edit_settings("Material", {"material": MATERIALS[name]})
            return name
        if kind == "angle":
            a = rng.choice([0.0, 15.0, 30.0, 45.0])
            win.edit_settings("Weft angle", {"angle_deg": a})
            return f"{a:g}"
        if kind == "tolerance":
            win.edit_settings("Tolerance", {"tol": rng.choice([1e-4, 1e-6, 1e-8])})
            return ""
        if kind == "solver":
            # the paper's scheme is slow: a time budget keeps each of its runs short
            name = rng.choice(["fast", "fast", "paper"])
            win.edit_settings("Solver", {"solver": name, "max_seconds": 5.0})
            return name
        if kind == "units":
            u = rng.choice(["mm", "cm", "m", "in"])
            win.edit_display("Units", {"units": u})
            return u
        if kind == "shear angles":
            w = rng.uniform(5, 20)
            win.edit_display("Shear angles", {"shear_warning_deg": w, "shear_limit_deg": w + rng.uniform(5, 20)})
            return ""
        if kind in ("run", "rerun"):
            (win.run if kind == "run" else win.rerun)()
            if rng.random() < 0.5:  # half the runs are left to finish, half are cut short by what follows
                self.settle()
                return "to its end"
            return ""
        if kind == "stop":
            win.stop()
            return ""
        if kind == "pause":
            if not win.runner.busy:
                return None
            win.toggle_pause()
            self.pump(rng.uniform(0, 200))
            if win.runner.paused:
                win.toggle_pause()
            return ""
        if kind == "undo":
            win.undo()
            return ""
        if kind == "redo":
            win.redo()
            return ""
        if kind == "save":
            self.saved = self.folder / "soak.flatweave"
            if not win.save_to(self.saved):
                self.errors["save failed"] += 1
            return ""
        if kind == "open" and self.saved is not None:
            if not win.open_file(self.saved):
                self.errors["open failed"] += 1
            return f"{self.saved.name}"
        if kind == "autosave":
            pending = win.autosave()
            if pending is not None:
                pending.result(timeout=60)
            return ""
        if kind == "example":
            from flatweave.reading.examples import example_names
            name = rng.choice(example_names())
            if not win.open_example(name):
                self.errors["example failed"] += 1
            return name + self.run_new_document()
        if kind in ("cad face", "mesh") and self.inputs.get(kind):
            path = rng.choice(self.inputs[kind])
            if not win.open_file(path):  # a refusal shows an error (counted by the check)
                return f"{path.name} refused"
            return path.name + self.run_new_document()
        if kind == "cad faces" and self.inputs.get(kind):
            return self.pick_faces(rng.choice(self.inputs[kind])) + self.run_new_document()
        if kind == "hostile" and self.inputs.get(kind):
            return self.open_hostile(rng.choice(self.inputs[kind]))
        if kind == "closed mesh" and self.inputs.get(kind):
            return self.draw_on_mesh(rng.choice(self.inputs[kind])) + self.run_new_document()
        if kind == "region":
            return self.draw_with_tool("tool_region", rng.randint(4, 7))
        if kind == "curve tool":
            return self.draw_with_tool("tool_curve_dart", rng.randint(2, 4))
        if kind == "suggest":
            return self.suggest()
        if kind == "sweep":
            return self.sweep()
        if kind == "export":
            return self.export()
        if kind == "view":
            return self.view_option()
        if kind == "zoom":
            return self.zoom()
        if kind == "turn":
            return self.turn()
        if kind == "reset view":
            win.actions["reset_view"].trigger()
            self._moved = self._turned = 0.0
            return ""
        return None

    # ------------------------------------------------------------------ edits through dialogs, tools and the mouse
    def run_new_document(self) -> str:
        """Most documents opened are solved at once (a designer's first step), some to the end."""
        if self.rng.random() >= 0.7:
            return ""
        self.win.run()
        if self.rng.random() < 0.5:
            self.settle()
            return ", run to its end"
        return ", run"

    def open_hostile(self, path: Path) -> str:
        """Open a file of the hostile corpus (tests/data/bad, tests/data/hostile; issue 45) through
        File > Open: it must be refused with one line shown and the document left as it was."""
        from flatweave.document.project import project_to_dict

        win = self.win
        if win.runner.state != "idle":
            win.stop()
            self.settle()
        before, revision = project_to_dict(win.project), win.document.revision
        shown, show = [], win.show_error
        win.show_error = shown.append
        try:
            opened = win.open_file(path)
        finally:
            win.show_error = show
        if opened or len(shown) != 1 or "\n" in shown[0] or win.document.revision != revision \
                or project_to_dict(win.project) != before:
            self.errors[f"hostile {path.name} not refused cleanly"] += 1
        return f"{path.name} refused"

    def pick_faces(self, path: Path) -> str | None:
        """Open a CAD file of several faces: in the face picker choose one, or
        join two neighbours (the fillet's plates), or cancel."""
        win, rng = self.win, self.rng
        if not win.open_file(path):
            return f"{path.name} refused"
        picker = win.files.face_picker
        if picker is None:
            return f"{path.name} opened without the picker"
        self.pump(100)
        r = rng.random()
        n = picker.list.count()
        if r < 0.15:
            picker.reject()
            choice = "cancelled"
        elif r < 0.6 or path.stem != "fillet":
            k = rng.randrange(n)
            picker.select(k)
            picker.accept()
            choice = f"face {k}"
        else:
            picker.select(0)
            picker.select(1, add=True)
            picker.accept()
            choice = "faces 0 and 1 joined"
        self.wait(lambda: win.files.face_picker is not None, 120)
        return f"{path.name}, {choice}"

    def draw_on_mesh(self, path: Path) -> str | None:
        """Open a closed mesh and draw the piece on it in the mesh picker (a ring round one end)."""
        win, rng = self.win, self.rng
        if not win.open_file(path):
            return f"{path.name} refused"
        picker = win.files.face_picker
        if picker is None:
            return f"{path.name} opened without the picker"
        self.pump(100)
        V = np.asarray(picker.opened.mesh.vertices)
        lo, hi = V.min(axis=0), V.max(axis=0)
        centre, half = (lo + hi) / 2, (hi - lo) / 2
        at = rng.uniform(0.3, 0.6) * rng.choice([-1, 1])  # where along x the ring goes round
        k = rng.randint(5, 9)
        t = np.linspace(0, 2 * np.pi, k, endpoint=False) + rng.uniform(0, 1)
        r = np.sqrt(1 - at ** 2)
        ring = centre + np.c_[np.full(k, at * half[0]), r * half[1] * np.cos(t), r * half[2] * np.sin(t)]
        for q in ring:
            picker.add_point(V[np.argmin(np.linalg.norm(V - q, axis=1))])
        picker.accept()
        self.wait(lambda: win.files.face_picker is not None, 120)
        return f"{path.name}, a ring of {k} points at x {at:+.2f}"

    def draw_with_tool(self, key: str, k: int) -> str | None:
        """Draw with a 3D view tool by real clicks: a region (a loop of ``k``
        points round a spot of the surface, closed on its first point or by
        Enter) or a curve dart (``k`` points in from the edge, Enter)."""
        win, rng, view = self.win, self.rng, self.win.view
        surface = self.doc.project.surface
        if key == "tool_region":
            cu, cv, r = rng.uniform(0.35, 0.65), rng.uniform(0.35, 0.65), rng.uniform(0.12, 0.3)
            t = np.linspace(0, 2 * np.pi, k, endpoint=False) + rng.uniform(0, 1)
            uv = np.array([self.uv_at(cu + r * np.cos(a), cv + r * np.sin(a)) for a in t])
        else:
            fv, depth = rng.uniform(0.25, 0.75), rng.uniform(0.25, 0.5)
            uv = np.array([self.uv_at(0.02 + depth * s, fv + 0.05 * s) for s in np.linspace(0, 1, k)])
        view.render_now()
        pixels = self.on_screen(view, surface.points(uv))
        if len(pixels) < 2:
            return None
        if not win.actions[key].isChecked():
            win.actions[key].trigger()
        for xy in pixels:
            self.click(view, xy)
            self.pump(rng.uniform(0, 80))
        if key == "tool_region" and rng.random() < 0.5:
            self.click(view, pixels[0])  # a click on the first point closes the loop
        else:
            win.finish_tool()
        if rng.random() < 0.7:
            win.set_tool(None)
        return f"{len(pixels)} clicks round uv {uv.mean(axis=0).round(4).tolist()} ({self.doc.undo_label or '-'})"

    def suggest(self) -> str | None:
        """Tools > Suggest darts: wait for the proposals, preview one, then apply or close."""
        win, rng = self.win, self.rng
        if win.project.result is None or not win.project.result_is_current or win.runner.busy:
            if not win.runner.busy:
                win.run()  # suggestions are made for a converged piece: solve first
            self.settle()
        if win.project.result is None or not win.project.result_is_current:
            return None
        box = win.suggest_dialog()
        if box is None:
            return None
        if not self.wait(lambda: box.busy, 300):
            self.errors["suggest took over 300 s"] += 1
        self.pump(50)
        n = len(box.proposals)
        if n and rng.random() < 0.7:
            box.list.setCurrentRow(rng.randrange(n))  # a preview in both views
            self.pump(rng.uniform(0, 300))
        said = box.status.text().split(";")[0][:70]
        if n and rng.random() < 0.6:
            box.apply()
            return f"{n} proposed, applied ({said})"
        box.close()
        return f"{n} proposed, closed ({said})"

    def sweep(self) -> str | None:
        """Solve > Best orientation over a few angles; apply the best or close."""
        win, rng = self.win, self.rng
        box = win.sweep_dialog()
        if box is None:
            return None
        box.angles.setValue(rng.randint(2, 4))
        box.start()
        if not self.wait(lambda: box.busy, 300):
            self.errors["sweep took over 300 s"] += 1
        self.pump(50)
        if box.result is not None and rng.random() < 0.6:
            box.apply()
            return f"{box.angles.value()} angles, applied"
        box.close()
        return f"{box.angles.value()} angles, closed"

    def export(self) -> str | None:
        from flatweave.export.registry import ExportOptions, exporters

        win, rng = self.win, self.rng
        if win.project.result is None or win.exports.busy:
            return None
        suffixes = rng.sample(sorted(e.suffix for e in exporters()), 2)[:rng.randint(1, 2)]  # the registry's
        paths = [self.folder / f"pattern{s}" for s in suffixes]
        failed = len(self.export_failures)
        if win.export_to(paths, ExportOptions()):
            self.wait(lambda: win.exports.busy, 120)
        self.pump(20)
        said = f", failed: {self.export_failures[-1]}" if len(self.export_failures) > failed else ""
        return " ".join(suffixes) + said

    VIEW_TOGGLES = ("mode_strain", "mode_shear", "mode_fibre", "show_weft", "show_warp", "show_diag",
                    "show_surface", "show_nodes", "show_fit_deviation", "show_fit_mesh")

    def view_option(self) -> str | None:
        """Flip one of the View menu's choices (never every spring kind off at once)."""
        win = self.win
        key = self.rng.choice(self.VIEW_TOGGLES)
        action = win.actions[key]
        if not action.isEnabled():
            return None
        kinds = [win.actions[k].isChecked() for k in ("show_weft", "show_warp", "show_diag")]
        if key.startswith("show_") and key[5:] in ("weft", "warp", "diag") and action.isChecked() and sum(kinds) == 1:
            return None
        action.trigger()
        if key == "show_fit_mesh":
            self._moved = self._turned = 0.0  # it frames the surface (and the mesh beside it) anew
        return f"{key} {'on' if action.isChecked() else 'off'}"

    def zoom(self) -> str | None:
        """The wheel over a point of the surface on screen (about it), within 4x of the framing either way."""
        view, rng = self.win.view, self.rng
        pts = view.surface_points
        if pts is None:
            return None
        pixels = self.on_screen(view, pts[rng.sample(range(len(pts)), min(40, len(pts)))])
        if not pixels:
            return None
        steps = rng.choice([-2, -1, 1, 2])
        if abs(self._moved + steps) > 7:
            steps = -steps
        x, y = rng.choice(pixels)
        view.zoom_at(x, y, 1.2 ** steps)
        self._moved += steps
        return f"{1.2 ** steps:.3g}x at ({x:.0f}, {y:.0f})"

    def turn(self) -> str | None:
        """A left drag in the 3D view with no tool: the camera turns."""
        from PySide6.QtCore import QPoint, Qt
        from PySide6.QtTest import QTest

        win, rng, view = self.win, self.rng, self.win.view
        if win.tool is not None:
            win.set_tool(None)
        if win.tool is not None:  # a selected curve dart's handles take the drag: leave them
            return None
        if self._turned > 150:  # far enough from the framing: the view is reset first (R)
            win.actions["reset_view"].trigger()
            self._moved = self._turned = 0.0
        w = view.widget
        a = QPoint(w.width() // 3 + rng.randrange(-30, 30), w.height() // 2 + rng.randrange(-30, 30))
        d = (rng.randrange(-40, 41), rng.randrange(-25, 26))
        QTest.mousePress(w, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a)
        for f in np.linspace(0, 1, 6)[1:]:
            QTest.mouseMove(w, QPoint(int(a.x() + f * d[0]), int(a.y() + f * d[1])))
        QTest.mouseRelease(w, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier,
                           QPoint(a.x() + d[0], a.y() + d[1]))
        self._turned += abs(d[0]) + abs(d[1])
        return f"by {d}"

    # ------------------------------------------------------------------ the checks
    def check(self) -> list[str]:
        from flatweave.document.project import project_problems, settings_equal
        from flatweave.app.worker import SolveThread

        problems = []
        win, doc = self.win, self.doc
        p = doc.project
        self.with_result += p.result is not None
        problems += project_problems(p)
        if p.result is not None and p.result_is_current and not settings_equal(p.result.settings, p.settings):
            problems.append("a result marked current was made with other settings")
        if len(doc.history) > doc.limit:
            problems.append(f"the undo stack holds {len(doc.history)} > {doc.limit} edits")
        from shiboken6 import isValid  # a finished thread's C++ side may be gone already (deleteLater)
        alive = [o for o in gc.get_objects() if isinstance(o, SolveThread) and isValid(o) and o.isRunning()] \
            if self.counts.total() % 25 == 0 else []
        self.max_threads = max(self.max_threads, len(alive))
        if len(alive) > 1:
            problems.append(f"{len(alive)} solve threads run at once")
        if win.actions["run"].isEnabled() != (win.runner.state == "idle"):
            problems.append(f"Run enabled={win.actions['run'].isEnabled()} while the runner is {win.runner.state}")
        if win.error_box is not None:  # a refused edit or a failed solve: note it, close the box
            self.errors[(win.last_error or "?").split(":")[0][:60]] += 1
            win.error_box.close()
        return problems

    # thresholds of a blank view: the share of its pixels (outside the colour bars and the axes) that differ
    # from the background. A framed surface covers a tenth to a half of the 3D view and a pattern a tenth or
    # more of its view (the soak's documents); a piece shrunk by the soak's zooms, or framed while the layout
    # squeezed the view and shown wider since, still covers a few thousandths, lines alone (the surface
    # hidden, no result: its rim) some ten-thousandths; a clipped scene draws none.
    MIN_SHARE_SURFACE = 0.001
    MIN_SHARE_LINES = 0.0001
    MIN_SHARE_PATTERN = 0.001

    def _document_grid(self, p) -> tuple[np.ndarray, np.ndarray]:
        """(grid, piece): the points of the presenter's grid of the document's surface, and
        those of the quads the 3D view draws (a trimmed piece's), cached per surface and region."""
        from flatweave.app.presenter import piece_grid

        key = (p.surface, p.settings.region)
        if self._grid_of is None or self._grid_of[0] is not key[0] or self._grid_of[1] is not key[1]:
            _, xyz, _, keep, _ = piece_grid(p.surface, p.settings.region)
            pts = grid = xyz.reshape(-1, 3)
            if keep is not None:
                n = xyz.shape[1]
                i, j = np.nonzero(keep)
                used = np.unique(np.concatenate([i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1, i * n + j + 1]))
                pts = pts[used]
            self._grid_of = (key[0], key[1], grid, pts)
        return self._grid_of[2], self._grid_of[3]

    def view_problems(self) -> list[str]:
        """Both views against the document: the 3D view's surface actor (in the renderer,
        visible as the options say, opaque, this document's surface), a result's mesh
        drawn in both views and its outline in the pattern (nothing running), the images
        not blank, and the camera seeing the surface (inside the frustum, not clipped)."""
        from flatweave.app.canvas import CanvasPlotter
        from PySide6.QtWidgets import QApplication

        win, doc = self.win, self.doc
        if doc is None or win.files.face_picker is not None:
            return []
        QApplication.processEvents()  # repaints already asked for land first
        self.view_checks += 1
        problems = []
        p = doc.project
        view, pattern = win.view, win.pattern_view
        opts = win.presenter.view_options
        ren = view.plotter.renderer
        actors = getattr(view, "_surface_actors", [])
        surface_on = bool(opts.surface)
        if not actors or not ren.HasViewProp(actors[0]):
            problems.append("3D view: the surface's actor is not in the renderer")
        elif bool(actors[0].GetVisibility()) != surface_on:
            problems.append(f"3D view: the surface's actor is {'shown' if actors[0].GetVisibility() else 'hidden'} "
                            f"with the Surface option {'on' if surface_on else 'off'}")
        elif actors[0].GetProperty().GetOpacity() < 0.99:
            problems.append(f"3D view: the surface's opacity is {actors[0].GetProperty().GetOpacity():.2f}")
        grid, piece = self._document_grid(p)
        shown = view.surface_points
        size = float(np.ptp(grid, axis=0).max())
        if shown is None or np.abs(np.r_[shown.min(0) - grid.min(0), shown.max(0) - grid.max(0)]).max() > 1e-6 * size:
            problems.append("3D view: it draws another surface than the document's")
        idle = win.runner.state == "idle"
        result = p.result if p.result is not None and p.result.surface is p.surface else None
        any_kind = opts.mode != "strain" or any(opts.kinds)
        if idle and result is not None and any_kind:
            for v, name in ((view, "3D view"), (pattern, "pattern view")):
                layer = v.layer
                drawn = [a for a in (*layer.spring_actors, layer.cell_actor, layer.strain_cell_actor)
                         if a.GetVisibility() and a.GetMapper().GetInput().GetNumberOfCells() > 0
                         and v.plotter.renderer.HasViewProp(a)]
                if layer.frame is None or not drawn:
                    problems.append(f"{name}: the document's result is not drawn")
            if result.pattern is not None and not pattern.outline.n_points:
                problems.append("pattern view: the result's outline is not drawn")
        # the pixels
        w3, h3 = view.device_size()
        bars = [(1.0 - view.bar_column_fraction(), 0.0, 1.0, 1.0), (0.0, 0.8, 0.2, 1.0)]  # colour bars, axes
        if opts.fit_deviation:
            bars.append((0.0, 0.5, (view._bar_width_px + 20) / w3, 1.0))  # the deviation's bar, bottom left
        for v, name, overlays in ((view, "3D view", bars), (pattern, "pattern view", ())):
            if name == "pattern view" and not (idle and result is not None and any_kind):
                continue
            need = (self.MIN_SHARE_PATTERN if name == "pattern view" else
                    self.MIN_SHARE_SURFACE if surface_on else self.MIN_SHARE_LINES)
            share = drawn_share(v, view_image(v), overlays)
            if share < need and isinstance(v.plotter, CanvasPlotter):
                v.widget.repaint()  # the canvas's last paint may be older than the scene: paint now and look again
                again = drawn_share(v, view_image(v), overlays)
                if again >= need:
                    problems.append(f"{name}: the image on screen is blank ({share:.4f} of the pixels drawn) "
                                    f"but a repaint draws {again:.4f}: a stale raster")
                share = again
            if share < need:
                cam = v.plotter.renderer.GetActiveCamera()
                problems.append(f"{name}: blank, {share:.4f} of the pixels drawn (at least {need} expected; "
                                f"{widget_state(v)}; clipping range {np.round(cam.GetClippingRange(), 6).tolist()}"
                                + (f", props beyond the surface: {stray_props(v, piece) or 'none'})"
                                   if v is view else ")"))
                self._keep_image(v, name)
            elif name == "3D view" and surface_on or name == "pattern view":
                self.shares[name].append(share)
        # the camera (the clipping range need not hold a hidden surface: VTK fits it to what is shown)
        inside, cut, n = frustum(view, piece)
        cam = ren.GetActiveCamera()
        if not inside:
            problems.append(f"3D view: the camera sees none of the surface's {n} points "
                            f"(camera at {np.round(cam.GetPosition(), 4).tolist()}, "
                            f"looking at {np.round(cam.GetFocalPoint(), 4).tolist()})")
        elif surface_on and cut > 0.01 * inside:
            problems.append(f"3D view: the clipping range {np.round(cam.GetClippingRange(), 6).tolist()} cuts off "
                            f"{cut} of the {inside} surface points in view (camera at "
                            f"{np.round(cam.GetPosition(), 6).tolist()}; the visible props' bounds "
                            f"{np.round(ren.ComputeVisiblePropBounds(), 6).tolist()}; beyond the surface: "
                            f"{stray_props(view, piece) or 'none'})")
        if idle and result is not None and pattern.layer.frame is not None:
            xy = np.asarray(pattern.layer.frame.xy, float)
            inside, cut, n = frustum(pattern, np.c_[xy, np.zeros(len(xy))])
            if not inside or cut > 0.01 * inside:
                problems.append(f"pattern view: the camera sees {inside} of the pattern's {n} nodes, {cut} clipped")
        return problems

    def _keep_image(self, view, name: str) -> None:
        """Save a blank view's image beside the soak's files (evidence)."""
        from PySide6.QtGui import QImage

        img = np.ascontiguousarray(view_image(view))
        h, w = img.shape[:2]
        path = self.folder / f"blank-{name.split()[0]}-{len(self.log)}.png"
        QImage(img.data, w, h, 3 * w, QImage.Format.Format_RGB888).save(str(path))
        print(f"  kept {path}", flush=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--edits", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--max-growth", type=float, default=5.0, metavar="MB",
                        help="fail if memory grows by more than this per 100 edits over the second half")
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks" / "results" / "soak.md")
    parser.add_argument("--view", choices=("auto", "gl", "canvas"), default=None,
                        help="the views' render widget (default: FLATWEAVE_VIEW, else auto)")
    parser.add_argument("--log", type=Path, default=None,
                        help="write every edit made to this file (default: edits.txt among the soak's files)")
    parser.add_argument("--size", default="1200x800", metavar="WxH", help="the window's size (default 1200x800)")
    parser.add_argument("--stop-on-blank", action="store_true",
                        help="end at the first failed view check (its image is kept beside the soak's files)")
    args = parser.parse_args(argv)

    os.environ.setdefault("QT_QPA_PLATFORM", "xcb")
    if args.view is not None:
        os.environ["FLATWEAVE_VIEW"] = args.view
    folder = Path(tempfile.mkdtemp(prefix="flatweave-soak-"))
    os.environ["FLATWEAVE_RECOVERY_DIR"] = str(folder / "recovery")
    log_path = args.log or folder / "edits.txt"
    print(f"the soak's files: {folder}", flush=True)

    from flatweave.app.nonefix import keep_none_alive

    keep_none_alive()  # before any Qt call
    from PySide6.QtWidgets import QApplication

    from flatweave.app.mainwindow import MainWindow
    from flatweave.reading.examples import example_path, load_example
    from flatweave.document.project import new_project

    app = QApplication.instance() or QApplication(["soak"])
    inputs = make_inputs(folder)
    win = MainWindow()
    win.resize(*(int(x) for x in args.size.lower().split("x")))
    surface = load_example("octant")
    win.set_project(new_project(surface, "octant", str(example_path("octant")), 0.12))
    win.show()
    rng = random.Random(args.seed)
    soak = Soak(win, rng, folder, inputs)
    soak.pump(500)
    base_threads = threading.active_count()
    from flatweave.app.canvas import view_kind
    kind_of_view = view_kind()

    t0 = time.perf_counter()
    memory, failures = [], []
    view_failures: list[str] = []
    first_blank: int | None = None
    for k in range(args.edits):
        try:
            kind = soak.edit()
        except Exception as exc:  # an edit that raised is a bug: record it, go on
            failures.append(f"edit {k}: {type(exc).__name__}: {exc}")
            soak.log.append(f"raised {type(exc).__name__}: {exc}")
            traceback.print_exc()
            kind = "raised"
        soak.pump(rng.uniform(0, 300))
        for problem in soak.check():
            failures.append(f"edit {k} ({kind}): {problem}")
        for problem in soak.view_problems():
            failures.append(f"edit {k} ({kind}): {problem}")
            view_failures.append(f"edit {k} ({soak.log[-1]}): {problem}")
            print(f"VIEW CHECK FAILED after edit {k} ({soak.log[-1]}): {problem}", flush=True)
            if first_blank is None:
                first_blank = k
        if threading.active_count() > base_threads + 4:
            names = Counter(t.name.rstrip("0123456789_") for t in threading.enumerate())
            failures.append(f"edit {k}: {threading.active_count()} threads (started with {base_threads}): "
                            + ", ".join(f"{n} x{c}" for n, c in sorted(names.items())))
        memory.append(rss_mb())
        if (k + 1) % 25 == 0:
            log_path.write_text("\n".join(f"{i}: {e}" for i, e in enumerate(soak.log)) + "\n")
        if (k + 1) % 100 == 0:
            print(f"{k + 1:5d} edits  {time.perf_counter() - t0:7.1f} s  RSS {memory[-1]:7.1f} MB  "
                  f"nodes {win.project.result.mesh.n_nodes if win.project.result else 0:5d}  "
                  f"failures {len(failures)}", flush=True)
        if first_blank is not None and args.stop_on_blank:
            break
    edits_made = len(soak.log)
    log_path.write_text("\n".join(f"{i}: {e}" for i, e in enumerate(soak.log)) + "\n")
    soak.settle()
    for problem in soak.check():
        failures.append(f"at the end: {problem}")
    for problem in soak.view_problems():
        failures.append(f"at the end: {problem}")
        view_failures.append(f"at the end: {problem}")
    seconds = time.perf_counter() - t0

    mem = np.array(memory)
    half = len(mem) // 2
    slope = float(np.polyfit(np.arange(half, len(mem)), mem[half:], 1)[0]) * 100 if len(mem) >= 20 else 0.0
    grew = slope > args.max_growth
    if grew:
        failures.append(f"memory grows {slope:.2f} MB per 100 edits over the second half "
                        f"(limit {args.max_growth:g})")
    win.close()
    leftovers = sorted(p.name for p in (folder / "recovery").glob("*")) if (folder / "recovery").exists() else []
    if leftovers:
        failures.append(f"recovery files left after a normal close: {leftovers}")

    lines = [
        "# Soak test",
        "",
        f"`tests/soak.py --edits {args.edits} --seed {args.seed} --view {kind_of_view} --size {args.size}`, "
        f"{time.strftime('%Y-%m-%d %H:%M')}, {platform.node()}, {os.cpu_count()} cores, "
        f"load {os.getloadavg()[0]:.2f} at the end.",
        "",
        "| measure | value |",
        "|---|---|",
        f"| edits | {edits_made} in {seconds:.0f} s |",
        f"| consistency failures | {len(failures)} |",
        f"| view checks (after each edit: actors, pixels, camera) | {soak.view_checks}, "
        f"{len(view_failures)} failed |",
        "| drawn share of the 3D view / pattern view (min, median) | "
        + " / ".join(f"{min(v):.3f}, {float(np.median(v)):.3f}" if v else "-" for v in soak.shares.values())
        + " |",
        f"| memory (RSS) first / at half / last / max | {mem[0]:.0f} / {mem[half]:.0f} / {mem[-1]:.0f} / "
        f"{mem.max():.0f} MB |",
        f"| memory trend over the second half | {slope:+.2f} MB per 100 edits (limit {args.max_growth:g}) |",
        f"| solve threads alive at once (sampled) | at most {soak.max_threads} |",
        f"| runs started | {win.runner.runs_started} (ended: "
        + ", ".join(f"{k} {v}" for k, v in soak.outcomes.most_common()) + "; the rest were replaced by "
        "a newer run or cancelled by an undo) |",
        f"| edits after which the document held a result | {soak.with_result} |",
        f"| undo stack at the end | {len(win.document.history)} (limit {win.document.limit}) |",
        "",
        "Edits made: " + ", ".join(f"{k} {v}" for k, v in sorted(soak.counts.items())) + ".",
        "",
        "Time per kind of edit (s, the pause after each edit not counted): "
        + ", ".join(f"{k} {v:.0f}" for k, v in soak.seconds.most_common()) + ".",
        "",
        "Errors shown to the user (refused edits, failed solves; expected, not failures): "
        + (", ".join(f"{k!r} {v}" for k, v in soak.errors.most_common()) or "none") + ".",
        "",
        *([f"Exports that failed: {'; '.join(soak.export_failures[:5])}.", ""] if soak.export_failures else []),
        *([f"Solves that failed: {'; '.join(soak.run_failures[:5])}.", ""] if soak.run_failures else []),
    ]
    if failures:
        lines += ["Failures:", ""] + [f"- {f}" for f in failures[:50]] + [""]
    if view_failures:
        k = first_blank if first_blank is not None else edits_made - 1
        lines += [f"The edits up to the first failed view check (edit {k}; seed {args.seed}; all of them in "
                  f"{log_path.name}):", ""] + [f"{i}. {e}" for i, e in enumerate(soak.log[:k + 1])][-40:] + [""]
    text = "\n".join(lines)
    print(text)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    app.processEvents()
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
