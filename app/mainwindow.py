"""The main window: the 3D view and the pattern view side by side, the
settings and progress dock, the metrics, menus, a toolbar and a status bar.

Structure (see docs/ARCHITECTURE.md):

* the document is a :class:`core.document.Document` (the current
  :class:`core.project.Project` with undo/redo); every user edit becomes one
  ``Document.apply``; the window listens to it (:meth:`_on_document_changed`)
  and redraws what changed. Nothing else changes the project.
* solves run in a :class:`app.runner.Runner` (one worker thread at a time);
  its frames are drawn as they come, its result is folded into the edit it
  answers (``Document.attach_result``).
* the views (:mod:`app.view3d`, :mod:`app.view2d`) own every VTK object and
  get numpy arrays (frames) and :class:`app.viewbase.ViewOptions`.
* every action is in ``self.actions``; :meth:`_update_actions` is the one place
  that enables them.
* the 3D view's tools (:mod:`app.tools`: draw a curve dart, place a plane
  dart, move a curve dart's points, pick a yarn) get the view's left-button
  events through :class:`_ToolMouse`, one tool at a time (:meth:`set_tool`),
  and commit through the document's dart and yarn edits; the darts and yarns
  panel (:mod:`app.dartpanel`) reports list edits the same way.
* work is never lost: a :class:`core.recovery.Session` autosaves the document
  (every minute when it changed, and after every solve) on a background
  thread; :meth:`check_recovery` offers back what a crashed session left;
  saves keep the last few versions as backups; closing with unsaved work asks
  first (when :attr:`MainWindow.confirm_close`, as the launcher sets it).
"""

from __future__ import annotations

import gc
import sys
import traceback
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import replace
from pathlib import Path

import numpy as np
from PySide6.QtCore import Qt, QTimer, Signal
from PySide6.QtGui import QAction, QActionGroup, QCursor, QKeySequence
from PySide6.QtWidgets import (QAbstractSpinBox, QApplication, QDockWidget, QFileDialog, QHBoxLayout, QLabel,
                               QLineEdit, QMainWindow, QMessageBox, QScrollArea, QSplitter, QTabWidget,
                               QToolButton, QToolTip, QVBoxLayout, QWidget)

from core.document import Change, Document
from core.energy import yarn_nodes
from core.errors import FlatweaveError
from core.export import ExportOptions
from core.examples import example_info, example_path, list_examples
from core.nurbs import NurbsSurface
from core.project import PROJECT_SUFFIX, Project, load_project, new_project, warm_start
from core.recovery import Orphan, Session, find_orphans, save_with_backups
from core.surface_io import load_surface

from app.dartpanel import DartPanel
from app.exporting import ExportDialog, ExportThread
from app.frames import FrameMaker
from app.panels import MetricsPanel, SettingsPanel
from app.plot import EnergyPlot
from app.runner import Runner
from app.tools import CurveDartTool, HandleEditor, PlaneDartTool, Tool, YarnTool
from app.view2d import PatternView
from app.view3d import SurfaceView
from app.viewbase import ViewOptions
from app.worker import RunOutcome, one_line

GRID_POINTS = 60
OPEN_FILTER = f"Projects and surfaces (*{PROJECT_SUFFIX} *.json);;Projects (*{PROJECT_SUFFIX});;" \
              "Surfaces (*.json);;All files (*)"
PROJECT_FILTER = f"flatweave projects (*{PROJECT_SUFFIX})"
RERUN_DELAY_MS = 250  # settings edits closer together than this make one re-run
AUTOSAVE_MS = 60_000  # the document is autosaved this often when it has changed (and after each solve)


_GC_FROZEN = False


def freeze_long_lived_objects() -> None:
    """Move every object alive now (modules, Qt and VTK wrappers, the window)
    out of the cyclic garbage collector's reach, once per process.

    Measured: with ~1 million objects from the imported libraries, a full
    collection triggered by the solve worker held the GIL for about 120 ms and
    stalled the event loop; after ``gc.freeze`` a full collection only walks
    objects made since, and the longest stall came from painting instead.
    Objects made later are collected as usual.
    """
    global _GC_FROZEN
    if not _GC_FROZEN:
        _GC_FROZEN = True
        gc.collect()
        gc.freeze()


class _ToolMouse:
    """The 3D view's left-button events, handed to the window's active tool.
    A tool's error becomes a one-line message: the view never sees it."""

    def __init__(self, window: "MainWindow"):
        self.window = window

    def _call(self, method: str, *args) -> bool:
        tool = self.window.tool
        if tool is None or self.window.document is None:
            return False
        try:
            return bool(getattr(tool, method)(*args))
        except Exception as exc:  # noqa: BLE001 (a tool's bug must not reach VTK's event loop)
            self.window.show_error(f"{tool.name}: {one_line(exc)}")
            return True

    def press(self, x, y, double):
        return self._call("press", x, y, double)

    def move(self, x, y):
        return self._call("move", x, y)

    def release(self, x, y):
        return self._call("release", x, y)


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


class MainWindow(QMainWindow):
    """flatweave's main window; one document at a time.

    Signals for scripts and tests: ``run_finished(RunOutcome)`` after a run's
    result has been handed to the document, ``run_failed(str)`` after a
    failed run's error has been shown; ``export_finished(paths)`` and
    ``export_failed(str)`` likewise for File > Export.
    """

    run_finished = Signal(object)
    run_failed = Signal(str)
    export_finished = Signal(object)  # list of the paths written
    export_failed = Signal(str)
    autosave_failed = Signal(str)  # from the autosave thread

    def __init__(self, parent: QWidget | None = None, recovery: bool = True):
        """``recovery``: autosave to a recovery file (see :mod:`core.recovery`)."""
        super().__init__(parent)
        self.document: Document | None = None
        self.last_error: str | None = None  # the last error shown, one line
        self.error_box: QMessageBox | None = None
        self.last_outcome: RunOutcome | None = None
        self.view_options = ViewOptions()
        self.frame = None  # the frame on screen
        self._first_nodes: int | None = None
        self._unsubscribe = None
        self._shown = False
        self.export_thread: ExportThread | None = None
        self.export_box: ExportDialog | None = None
        self.last_export: list[Path] = []
        self.export_options = ExportOptions()  # the last choices (units come from the project)
        self._export_every_format = False

        self.view = SurfaceView(self)
        self.pattern_view = PatternView(self)
        self.view.hover_callback = self._show_hover
        self.pattern_view.hover_callback = self._show_hover
        self.metrics = MetricsPanel(self)
        self.settings_panel = SettingsPanel(self)
        self.dart_panel = DartPanel(self)
        self.tool: Tool | None = None
        self.selected_dart: int | None = None
        self.last_hint: str | None = None  # the last hint a tool gave (also in the status bar)
        self._curve_cache: dict = {}
        self.view.mouse_handler = _ToolMouse(self)
        self.energy_plot = EnergyPlot(self)
        self.progress = QLabel("Open a surface or pick an example, then Run.", self)
        self.progress.setWordWrap(True)
        self.runner = Runner(self)
        self._rerun_timer = QTimer(self, singleShot=True, interval=RERUN_DELAY_MS)
        self._rerun_timer.timeout.connect(self.rerun)
        self.confirm_close = False  # ask before closing with unsaved work (the launcher turns it on)
        self.session: Session | None = None
        self.recovery_box: QMessageBox | None = None
        self.recovery_problem: str | None = None
        if recovery:
            try:
                self.session = Session()
            except (FlatweaveError, OSError) as exc:
                self.recovery_problem = f"Autosave is off: {exc}"
        self._autosaver = ThreadPoolExecutor(max_workers=1, thread_name_prefix="flatweave-autosave")
        self._autosaved_revision: int | None = None
        self.last_autosave: Future | None = None
        self._autosave_timer = QTimer(self, interval=AUTOSAVE_MS)
        self._autosave_timer.timeout.connect(self.autosave)
        self._autosave_timer.start()
        self.autosave_failed.connect(lambda m: self.statusBar().showMessage(m, 10000))

        self.actions = self._create_actions()
        self._build_layout()
        self._create_menus()
        self._create_toolbar()
        self._hover_label = QLabel(self)
        self._name_label = QLabel(self)
        self._info_label = QLabel(self)
        self.statusBar().addWidget(self._name_label)
        self.statusBar().addWidget(self._hover_label, 1)
        self.statusBar().addPermanentWidget(self._info_label)
        self._connect()
        self.resize(1500, 920)
        self._update_actions()
        self._update_title()
        freeze_long_lived_objects()

    # ------------------------------------------------------------------ building
    def _build_layout(self) -> None:
        right = QSplitter(Qt.Orientation.Vertical, self)
        right.addWidget(self.pattern_view.widget)
        right.addWidget(self.metrics)
        right.setStretchFactor(0, 4)
        right.setStretchFactor(1, 0)
        split = QSplitter(Qt.Orientation.Horizontal, self)
        split.addWidget(self.view.widget)
        split.addWidget(right)
        split.setStretchFactor(0, 1)
        split.setStretchFactor(1, 1)
        split.setSizes([620, 560])
        self.setCentralWidget(split)

        side = QWidget(self)
        col = QVBoxLayout(side)
        col.setContentsMargins(4, 4, 4, 4)
        self.side_tabs = QTabWidget(side)
        self.side_tabs.addTab(self.settings_panel, "Settings")
        self.side_tabs.addTab(self.dart_panel, "Darts and yarns")
        col.addWidget(self.side_tabs)
        buttons = QHBoxLayout()
        for key in ("run", "pause", "stop"):
            b = QToolButton(side)
            b.setDefaultAction(self.actions[key])
            b.setToolButtonStyle(Qt.ToolButtonStyle.ToolButtonTextOnly)
            b.setMinimumWidth(70)
            buttons.addWidget(b)
        buttons.addStretch(1)
        col.addLayout(buttons)
        col.addWidget(self.progress)
        col.addWidget(self.energy_plot, 1)
        scroll = QScrollArea(self)
        scroll.setWidget(side)
        scroll.setWidgetResizable(True)
        scroll.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
        dock = QDockWidget("Settings", self)
        dock.setObjectName("settings-dock")
        dock.setWidget(scroll)
        dock.setFeatures(QDockWidget.DockWidgetFeature.DockWidgetMovable)
        dock.setMinimumWidth(330)
        self.addDockWidget(Qt.DockWidgetArea.LeftDockWidgetArea, dock)

    def _create_actions(self) -> dict[str, QAction]:
        def act(text, slot=None, shortcut=None, tip=None, checkable=False, checked=False):
            a = QAction(text, self)
            if shortcut is not None:
                a.setShortcut(shortcut)
            if tip:
                a.setStatusTip(tip)
                a.setToolTip(tip)
            if checkable:
                a.setCheckable(True)
                a.setChecked(checked)
                if slot is not None:
                    a.toggled.connect(slot)
            elif slot is not None:
                a.triggered.connect(slot)
            return a

        acts = {
            "open": act("&Open...", self.open_dialog, QKeySequence.StandardKey.Open,
                        "Open a project (.flatweave) or a surface (geomdl JSON)"),
            "save": act("&Save", self.save, QKeySequence.StandardKey.Save, "Save the project"),
            "save_as": act("Save &As...", self.save_as, QKeySequence.StandardKey.SaveAs,
                           "Save the project under a new name"),
            "export": act("&Export pattern...", self.export_dialog, "Ctrl+E",
                          "Write the pattern as DXF, SVG, tiled PDF, VTP or OBJ"),
            "quit": act("&Quit", self.close, QKeySequence.StandardKey.Quit),
            "undo": act("&Undo", self.undo, QKeySequence.StandardKey.Undo),
            "redo": act("&Redo", self.redo, QKeySequence.StandardKey.Redo),
            "run": act("&Run", self.run, "F5", "Drape the mesh and minimise its energy"),
            "pause": act("&Pause", self.toggle_pause, "F6", "Pause or resume the solve"),
            "stop": act("&Stop", self.stop, "Shift+F5", "Stop the solve; keep the last iterate"),
            "reset_view": act("&Reset 3D view", self.view.reset_camera, "R"),
            "fit_pattern": act("&Fit pattern", self.pattern_view.fit, "F"),
            "mode_strain": act("&Strain", lambda on: on and self.set_view_options(mode="strain"), "1",
                               "Colour springs by strain: red tensile, green zero, blue compressive",
                               checkable=True, checked=True),
            "mode_shear": act("S&hear", lambda on: on and self.set_view_options(mode="shear"), "2",
                              "Colour cells by shear angle against the warning and limit angles",
                              checkable=True),
            "show_weft": act("&Weft", lambda on: self.set_view_options(weft=on), None, "Show weft springs",
                             checkable=True, checked=True),
            "show_warp": act("W&arp", lambda on: self.set_view_options(warp=on), None, "Show warp springs",
                             checkable=True, checked=True),
            "show_diag": act("&Diagonal", lambda on: self.set_view_options(diag=on), None,
                             "Show diagonal springs", checkable=True, checked=True),
            "show_surface": act("S&urface", lambda on: self.set_view_options(surface=on), None,
                                "Show the surface under the mesh", checkable=True, checked=True),
            "show_nodes": act("&Nodes", lambda on: self.set_view_options(nodes=on), None,
                              "Show boundary nodes (yellow) and dart nodes (red, blue)",
                              checkable=True, checked=True),
            "tool_curve_dart": act("&Curve dart", lambda on: self._tool_toggled(CurveDartTool, on), "D",
                                   "Draw a curve dart: click points on the surface, Enter finishes",
                                   checkable=True),
            "tool_plane_dart": act("&Plane dart", lambda on: self._tool_toggled(PlaneDartTool, on), "P",
                                   "Place a plane dart with a plane and a box, or numbers", checkable=True),
            "tool_yarn": act("&Yarn", lambda on: self._tool_toggled(YarnTool, on), "Y",
                             "Pick a yarn to hold to a plane: click a node of the mesh", checkable=True),
            "tool_finish": act("&Finish", self.finish_tool, None, "Make the dart or constraint (Enter)"),
            "tool_cancel": act("Ca&ncel", self.cancel_tool, "Esc", "Drop the dart or yarn being made (Esc)"),
            "tool_back": act("Take &back a point", self.back_tool, "Backspace",
                             "Remove the last point of the dart being drawn"),
        }
        acts["tool_finish"].setShortcuts([QKeySequence(Qt.Key.Key_Return), QKeySequence(Qt.Key.Key_Enter)])
        redo_keys = list(QKeySequence.keyBindings(QKeySequence.StandardKey.Redo))
        if QKeySequence("Ctrl+Y") not in redo_keys:
            redo_keys.append(QKeySequence("Ctrl+Y"))
        acts["redo"].setShortcuts(redo_keys)
        group = QActionGroup(self)
        group.setExclusive(True)
        group.addAction(acts["mode_strain"])
        group.addAction(acts["mode_shear"])
        for key in ("reset_view", "fit_pattern", "mode_strain", "mode_shear", "run", "pause", "stop",
                    "tool_curve_dart", "tool_plane_dart", "tool_yarn", "tool_finish", "tool_cancel", "tool_back"):
            acts[key].setShortcutContext(Qt.ShortcutContext.WindowShortcut)
        return acts

    def _create_menus(self) -> None:
        bar = self.menuBar()
        file_menu = bar.addMenu("&File")
        for key in ("open", "save", "save_as"):
            file_menu.addAction(self.actions[key])
        file_menu.addSeparator()
        file_menu.addAction(self.actions["export"])
        file_menu.addSeparator()
        file_menu.addAction(self.actions["quit"])
        edit_menu = bar.addMenu("&Edit")
        edit_menu.addAction(self.actions["undo"])
        edit_menu.addAction(self.actions["redo"])
        self.examples_menu = bar.addMenu("E&xamples")
        try:
            examples = list_examples()
        except (FlatweaveError, OSError, ValueError):  # a broken install: no menu entries
            examples = []
        for entry in examples:
            name = entry["name"]
            a = QAction(entry.get("title") or name, self)
            a.setData(name)
            if entry.get("description"):
                a.setStatusTip(entry["description"])
            a.triggered.connect(lambda checked=False, n=name: self.open_example(n))
            self.examples_menu.addAction(a)
        if not examples:
            self.examples_menu.addAction("(no examples found)").setEnabled(False)
        tools_menu = bar.addMenu("&Tools")
        for key in ("tool_curve_dart", "tool_plane_dart", "tool_yarn"):
            tools_menu.addAction(self.actions[key])
        tools_menu.addSeparator()
        for key in ("tool_finish", "tool_back", "tool_cancel"):
            tools_menu.addAction(self.actions[key])
        solve_menu = bar.addMenu("&Solve")
        for key in ("run", "pause", "stop"):
            solve_menu.addAction(self.actions[key])
        view_menu = bar.addMenu("&View")
        for key in ("mode_strain", "mode_shear"):
            view_menu.addAction(self.actions[key])
        view_menu.addSeparator()
        for key in ("show_weft", "show_warp", "show_diag", "show_surface", "show_nodes"):
            view_menu.addAction(self.actions[key])
        view_menu.addSeparator()
        view_menu.addAction(self.actions["reset_view"])
        view_menu.addAction(self.actions["fit_pattern"])

    def _create_toolbar(self) -> None:
        tb = self.addToolBar("Main")
        tb.setObjectName("main-toolbar")
        tb.setMovable(False)
        for key in ("run", "pause", "stop"):
            tb.addAction(self.actions[key])
        tb.addSeparator()
        for key in ("mode_strain", "mode_shear"):
            tb.addAction(self.actions[key])
        tb.addSeparator()
        for key in ("show_weft", "show_warp", "show_diag", "show_surface", "show_nodes"):
            tb.addAction(self.actions[key])
        tb.addSeparator()
        for key in ("tool_curve_dart", "tool_plane_dart", "tool_yarn"):
            tb.addAction(self.actions[key])
        tb.addSeparator()
        tb.addAction(self.actions["reset_view"])
        tb.addAction(self.actions["fit_pattern"])

    def _connect(self) -> None:
        self.settings_panel.settings_edited.connect(self.edit_settings)
        self.settings_panel.display_edited.connect(self.edit_display)
        self.settings_panel.input_error.connect(self.show_error)
        dp = self.dart_panel
        dp.set_actions(self.actions["tool_curve_dart"], self.actions["tool_plane_dart"], self.actions["tool_yarn"])
        dp.dart_selected.connect(lambda row: self.select_dart(row if row >= 0 else None))
        dp.dart_renamed.connect(lambda row, name: self._dart_edit(self.document.rename_dart, row, name))
        dp.dart_visibility.connect(lambda row, on: self._dart_edit(self.document.set_dart_visible, row, on))
        dp.dart_delete.connect(self.delete_dart)
        dp.dart_edit.connect(self.edit_dart)
        dp.plane_values.connect(self._plane_values)
        dp.plane_apply.connect(self.finish_tool)
        dp.plane_cancel.connect(lambda: self.set_tool(None))
        dp.yarn_selected.connect(lambda _row: self._show_yarns(self.project))
        dp.yarn_remove.connect(lambda row: self._dart_edit(self.document.remove_yarn, row))
        dp.yarn_edit.connect(self.edit_yarn)
        dp.yarn_choice.connect(self._yarn_choice)
        dp.yarn_apply.connect(self.finish_tool)
        dp.yarn_cancel.connect(self.cancel_tool)
        dp.input_error.connect(self.show_error)
        r = self.runner
        r.frame.connect(self._draw_frame)
        r.started.connect(self._run_started)
        r.finished.connect(self._run_finished)
        r.failed.connect(self._run_failed)
        r.cancelled.connect(self._run_cancelled)
        r.state_changed.connect(lambda _s: self._update_actions())

    # ------------------------------------------------------------------ actions
    def _update_actions(self) -> None:
        """Enable, disable and name the actions for the current state (the one place that does)."""
        a = self.actions
        has_doc = self.document is not None
        state = self.runner.state
        a["run"].setEnabled(has_doc and state == "idle")
        a["pause"].setEnabled(state in ("running", "paused"))
        a["pause"].setText("&Resume" if state == "paused" else "&Pause")
        a["stop"].setEnabled(state in ("running", "paused"))
        for key in ("save", "save_as", "reset_view", "fit_pattern"):
            a[key].setEnabled(has_doc)
        doc = self.document
        a["export"].setEnabled(bool(doc and doc.project.result is not None) and self.export_thread is None)
        a["undo"].setEnabled(bool(doc and doc.can_undo))
        a["redo"].setEnabled(bool(doc and doc.can_redo))
        a["undo"].setText(f"&Undo {doc.undo_label}" if doc and doc.can_undo else "&Undo")
        a["redo"].setText(f"&Redo {doc.redo_label}" if doc and doc.can_redo else "&Redo")
        self.settings_panel.setEnabled(has_doc)
        self.dart_panel.setEnabled(has_doc)
        tool = self.tool
        for key, kind in (("tool_curve_dart", CurveDartTool), ("tool_plane_dart", PlaneDartTool),
                          ("tool_yarn", YarnTool)):
            a[key].setEnabled(has_doc)
            a[key].blockSignals(True)
            a[key].setChecked(isinstance(tool, kind))
            a[key].blockSignals(False)
        making = tool is not None and not isinstance(tool, HandleEditor)
        for key in ("tool_finish", "tool_cancel"):
            a[key].setEnabled(making)
        a["tool_back"].setEnabled(isinstance(tool, CurveDartTool))

    def _update_title(self) -> None:
        doc = self.document
        if doc is None:
            self.setWindowTitle("flatweave")
            return
        name = doc.path.name if doc.path is not None else self.surface_name
        self.setWindowTitle(f"flatweave - {name}{' *' if doc.dirty else ''}")

    # ------------------------------------------------------------------ document access
    @property
    def project(self) -> Project | None:
        return None if self.document is None else self.document.project

    @property
    def surface(self) -> NurbsSurface | None:
        return None if self.document is None else self.document.project.surface

    @property
    def surface_name(self) -> str | None:
        return None if self.document is None else self.document.project.name

    def set_project(self, project: Project, path: str | Path | None = None, saved: bool = True) -> None:
        """Make ``project`` the document (a new history); any run is abandoned.
        ``saved=False``: it is not what ``path`` holds (a recovered autosave)."""
        self.runner.cancel()
        self._rerun_timer.stop()
        if self.document is None:
            self.document = Document(project, path)
            if not saved:
                self.document.reset(project, path, saved=False)
            self._unsubscribe = self.document.subscribe(self._on_document_changed)
            self._on_document_changed(project, Change("reset", frozenset(
                ("surface", "settings", "display", "result", "name"))))
        else:
            self.document.reset(project, path, saved=saved)

    def set_surface(self, surface: NurbsSurface, path: str | Path | None = None, spacing: float | None = None,
                    units: str = "m") -> None:
        """A new document on ``surface`` (loaded from ``path``) with default settings."""
        name = Path(path).stem if path is not None else "untitled"
        self.set_project(new_project(surface, name, None if path is None else str(path), spacing, units))

    def open_file(self, path: str | Path) -> bool:
        """Open a project (.flatweave) or a surface file; on failure show the error, keep the document."""
        path = Path(path)
        try:
            if path.suffix.lower() == PROJECT_SUFFIX:
                project = load_project(path)
                self.set_project(project, path)
            else:
                surface = load_surface(path)
                self.set_surface(surface, path)
        except (FlatweaveError, OSError) as exc:
            what = "project" if path.suffix.lower() == PROJECT_SUFFIX else "surface"
            self.show_error(f"Cannot open {what}: {exc}")
            return False
        self.statusBar().showMessage(f"Opened {path}", 5000)
        return True

    def open_example(self, name: str) -> bool:
        """Open a bundled example with its recommended spacing and units."""
        try:
            info = example_info(name)
            path = example_path(name)
            surface = load_surface(path)
        except (FlatweaveError, OSError) as exc:
            self.show_error(f"Cannot open example {name}: {exc}")
            return False
        self.set_surface(surface, path, spacing=info.get("recommended_spacing"), units=info.get("units", "m")
                         if info.get("units") in ("mm", "cm", "m", "in") else "m")
        self.statusBar().showMessage(f"Opened the example {info.get('title') or name}", 5000)
        return True

    def open_dialog(self) -> None:
        start = str(self.document.path.parent) if self.document and self.document.path else ""
        path, _ = QFileDialog.getOpenFileName(self, "Open project or surface", start, OPEN_FILTER)
        if path:
            self.open_file(path)

    def save(self) -> bool:
        if self.document is None:
            return False
        if self.document.path is None or self.document.path.suffix.lower() != PROJECT_SUFFIX:
            return self.save_as()
        return self.save_to(self.document.path)

    def save_as(self) -> bool:
        if self.document is None:
            return False
        doc = self.document
        start = str(doc.path.with_suffix(PROJECT_SUFFIX)) if doc.path else f"{self.surface_name}{PROJECT_SUFFIX}"
        path, _ = QFileDialog.getSaveFileName(self, "Save project", start, PROJECT_FILTER)
        return bool(path) and self.save_to(path)

    def save_to(self, path: str | Path) -> bool:
        """Save the project to ``path`` (``.flatweave`` added if missing)."""
        path = Path(path)
        if path.suffix.lower() != PROJECT_SUFFIX:
            path = path.with_name(path.name + PROJECT_SUFFIX)
        try:
            save_with_backups(self.document.project, path)
        except Exception as exc:  # any failure is said, in one line; the document stays unsaved (dirty)
            if not isinstance(exc, FlatweaveError):  # a bug, not a user error: keep its traceback
                traceback.print_exc(file=sys.stderr)
            self.show_error(f"Cannot save: {one_line(exc)}")
            return False
        self.document.mark_saved(path)
        self.autosave()  # nothing left to recover
        self.statusBar().showMessage(f"Saved {path}", 5000)
        return True

    # ------------------------------------------------------------------ autosave and recovery
    def autosave(self) -> Future | None:
        """Write the document to this session's recovery file if it changed
        since the last autosave (or clear the file when nothing is unsaved).
        The write runs on the autosave thread; returns its Future (None if
        there was nothing to do)."""
        doc = self.document
        if self.session is None or doc is None or doc.revision == self._autosaved_revision:
            return None
        self._autosaved_revision = doc.revision
        if doc.unsaved_work:
            self.last_autosave = self._autosaver.submit(self._write_recovery, doc.project, doc.path)
        else:
            self.last_autosave = self._autosaver.submit(self.session.clear)
        return self.last_autosave

    def _write_recovery(self, project: Project, path) -> None:  # on the autosave thread
        try:
            self.session.write(project, path)
        except FlatweaveError as exc:
            self._autosaved_revision = None  # try again at the next tick
            self.autosave_failed.emit(f"Autosave failed: {exc}")

    def check_recovery(self, folder: str | Path | None = None) -> Orphan | None:
        """Offer back the newest document a crashed flatweave left (a
        non-blocking question: Recover, Discard, or Later). Returns what is offered."""
        if self.recovery_box is not None:
            return None
        if folder is None and self.session is None:
            return None
        orphans = find_orphans(self.session.folder if folder is None else folder)
        if not orphans:
            return None
        offered, rest = orphans[0], orphans[1:]
        for other in rest:  # offered one at a time: the others at the next check
            other.release()
        box = QMessageBox(QMessageBox.Icon.Question, "flatweave: recover unsaved work",
                          f"flatweave did not close normally. Recover the work it autosaved?\n\n"
                          f"{offered.describe()}", QMessageBox.StandardButton.NoButton, self)
        recover = box.addButton("Recover", QMessageBox.ButtonRole.AcceptRole)
        discard = box.addButton("Discard", QMessageBox.ButtonRole.DestructiveRole)
        box.addButton("Later", QMessageBox.ButtonRole.RejectRole)
        box.setDefaultButton(recover)
        box.setWindowModality(Qt.WindowModality.NonModal)
        box.setAttribute(Qt.WidgetAttribute.WA_DeleteOnClose)

        def answered(_result):
            clicked = box.clickedButton()
            self.recovery_box = None
            if clicked is recover:
                self.recover(offered)
            elif clicked is discard:
                offered.discard()
                self.statusBar().showMessage("Discarded the autosaved work.", 5000)
            else:
                offered.release()
            if rest and clicked in (recover, discard):
                QTimer.singleShot(0, lambda: self.check_recovery(folder))

        box.finished.connect(answered)
        self.recovery_box = box
        box.show()
        return offered

    def recover(self, orphan: Orphan) -> bool:
        """Open ``orphan``'s autosave as the document (unsaved; Save writes it
        where it was saved before), then delete the recovery file once this
        session's own autosave holds the work."""
        try:
            project = orphan.load()
        except FlatweaveError as exc:
            orphan.release()
            self.show_error(f"Cannot recover {orphan.path}: {exc}")
            return False
        self.set_project(project, orphan.document_path, saved=False)
        pending = self.autosave()
        if pending is not None:
            pending.result()
        orphan.discard()
        self.statusBar().showMessage(f"Recovered {orphan.describe()}; save it to keep it.", 10000)
        return True

    # ------------------------------------------------------------------ export
    def _export_start_path(self) -> Path:
        if self.last_export:
            return self.last_export[0]
        doc = self.document
        folder = doc.path.parent if doc.path is not None else Path.cwd()
        return folder / f"{self.surface_name or 'pattern'}.dxf"

    def export_dialog(self) -> None:
        """Ask where and how to export the document's pattern, then export it."""
        project = self.project
        if project is None or project.result is None:
            return
        o = self.export_options
        dialog = ExportDialog(self._export_start_path(), project.units, project.name, o.seam_allowance_mm, o.paper,
                              self._export_every_format, stale=not project.result_is_current, parent=self)
        dialog.setAttribute(Qt.WidgetAttribute.WA_DeleteOnClose)
        self.export_box = dialog

        def accepted():
            self._export_every_format = dialog.every_format.isChecked()
            self.export_to(dialog.paths(), dialog.options())
        dialog.accepted.connect(accepted)
        dialog.open()

    def export_to(self, paths, options: ExportOptions) -> bool:
        """Write the document's result to ``paths`` (formats from their suffixes) in a
        background thread; ``export_finished`` or ``export_failed`` follows."""
        project = self.project
        if project is None or project.result is None or self.export_thread is not None:
            return False
        self.export_options = options
        t = ExportThread(project.result, [Path(p) for p in paths], options)
        t.succeeded.connect(self._export_succeeded)
        t.failed.connect(self._export_failed)
        t.finished.connect(self._export_thread_finished)
        self.export_thread = t
        self.statusBar().showMessage(f"Exporting {', '.join(Path(p).name for p in paths)}...")
        self._update_actions()
        t.start()
        return True

    def _export_succeeded(self, written) -> None:
        self.last_export = list(written)
        folder = written[0].parent if written else Path(".")
        names = ", ".join(p.name for p in written)
        text = f"Exported {names} to {folder}"
        self.statusBar().showMessage(text, 15000)
        self.progress.setText(text)
        self.export_finished.emit(list(written))

    def _export_failed(self, message: str) -> None:
        self.show_error(f"Export failed: {message}")
        self.export_failed.emit(message)

    def _export_thread_finished(self) -> None:
        t, self.export_thread = self.export_thread, None
        if t is not None:
            t.wait()
            t.deleteLater()
        self._update_actions()

    # ------------------------------------------------------------------ edits
    def edit_settings(self, label: str, changes: dict) -> bool:
        """One undoable edit of FlattenSettings fields; refused values show an error."""
        if self.document is None:
            return False
        try:
            self.document.edit_settings(label, **changes)
        except (FlatweaveError, TypeError, ValueError) as exc:
            self.show_error(f"{label}: {exc}")
            self.settings_panel.set_project(self.document.project)
            return False
        return True

    def edit_display(self, label: str, changes: dict) -> bool:
        """One undoable edit of units or shear angles."""
        if self.document is None:
            return False
        try:
            self.document.edit_display(label, **changes)
        except (FlatweaveError, TypeError, ValueError) as exc:
            self.show_error(f"{label}: {exc}")
            self.settings_panel.set_project(self.document.project)
            return False
        return True

    def undo(self) -> None:
        if self.document is not None:
            self.document.undo()

    def redo(self) -> None:
        if self.document is not None:
            self.document.redo()

    def _on_document_changed(self, project: Project, change: Change) -> None:
        aspects = change.aspects
        if (self.runner.active and change.cause in ("undo", "redo", "reset")
                and aspects & {"surface", "settings"}):
            self.runner.cancel()  # it solves a project the document has left: its result would be refused
        if "surface" in aspects:
            _, xyz, normals = surface_grid(project.surface)
            self.view.set_surface(xyz, normals)
            self.pattern_view.clear_frame()
            self.frame = None
            p, q = project.surface.degree_u, project.surface.degree_v
            nu, nv = project.surface.shape
            kind = "rational" if project.surface.rational else "polynomial"
            self._info_label.setText(f"{kind}, degree {p}x{q}, {nu}x{nv} control points")
        if aspects & {"settings", "display", "name"} or change.cause in ("reset", "undo", "redo"):
            self.settings_panel.set_project(project)
        if "surface" in aspects or change.cause == "reset":
            self.set_tool(None)
            self.selected_dart = None
            self._curve_cache.clear()
        elif change.cause in ("undo", "redo") and aspects & {"settings", "labels"} and self.tool is not None:
            self.set_tool(None)  # the tool was working on a dart or yarn list that is gone now
        if aspects & {"settings", "labels", "surface"} or change.cause in ("reset", "undo", "redo"):
            darts = project.settings.darts
            if self.selected_dart is not None and self.selected_dart >= len(darts):
                self.selected_dart = None
            self.dart_panel.set_project(project, self.selected_dart)
            self._show_darts(project)
            self._refresh_handles()
        if aspects & {"settings", "result", "surface"} or change.cause in ("reset", "undo", "redo"):
            self._show_yarns(project)
        if "result" in aspects and isinstance(self.tool, YarnTool):
            self.tool.result_changed()
        if "display" in aspects:
            self.set_view_options(units=project.units, shear_warning_deg=project.shear_warning_deg,
                                  shear_limit_deg=project.shear_limit_deg)
        if change.cause != "result" and (aspects & {"result", "surface"} or change.cause in ("undo", "redo")) \
                and not self.runner.active:
            self.show_result(project)
        elif self.frame is not None:
            self.metrics.show_frame(self.frame, project, stale=not project.result_is_current)
        self._name_label.setText(project.name)
        if (change.cause == "edit" and "settings" in aspects and self.settings_panel.auto_rerun.isChecked()
                and (project.result is not None or self.runner.busy)):
            self._rerun_timer.start()
        self._update_actions()
        self._update_title()

    # ------------------------------------------------------------------ tools, darts and yarns
    def hint(self, text: str) -> None:
        """A tool's hint, in the status bar."""
        self.last_hint = text
        self.statusBar().showMessage(text, 10000)

    def set_tool(self, tool: Tool | None) -> None:
        """Make ``tool`` the 3D view's tool (None: none; a selected curve dart's
        points can then be dragged)."""
        old, self.tool = self.tool, None
        if old is not None:
            try:
                old.deactivate()
            except Exception as exc:  # noqa: BLE001 (never leave the window in a half-switched state)
                self.show_error(f"{old.name}: {one_line(exc)}")
        if tool is None:
            tool = self._handle_editor()
        self.tool = tool
        if tool is not None:
            if not isinstance(tool, HandleEditor):
                self.side_tabs.setCurrentWidget(self.dart_panel)
            try:
                tool.activate()
            except Exception as exc:  # noqa: BLE001
                self.tool = None
                self.show_error(f"{tool.name}: {one_line(exc)}")
        self._update_actions()

    def _tool_toggled(self, kind, on: bool) -> None:
        if self.document is None:
            return
        if on and not isinstance(self.tool, kind):
            self.set_tool(kind(self))
        elif not on and isinstance(self.tool, kind):
            self.set_tool(None)

    def _handle_editor(self) -> HandleEditor | None:
        """The editor of the selected curve dart's points, if a curve dart is selected and shown."""
        k, doc = self.selected_dart, self.document
        if doc is None or k is None or k >= len(doc.project.settings.darts):
            return None
        dart = doc.project.settings.darts[k]
        return HandleEditor(self, k) if dart.kind == "curve" and dart.visible else None

    def _refresh_handles(self) -> None:
        if self.tool is None or isinstance(self.tool, HandleEditor):
            self.set_tool(None)

    def _commit_typing(self) -> bool:
        """Enter while a field has the focus commits what was typed there (the
        field loses the focus, which ends its editing). True when Enter should
        also act on the tool: the field was the tool's own (in the darts panel)."""
        w = QApplication.focusWidget()
        if isinstance(w, (QLineEdit, QAbstractSpinBox)):
            w.clearFocus()
            return self.dart_panel.isAncestorOf(w)
        return True

    def finish_tool(self) -> None:
        if self.tool is not None:
            if not self._commit_typing():
                return
            try:
                self.tool.finish()
            except Exception as exc:  # noqa: BLE001
                self.show_error(f"{self.tool.name}: {one_line(exc)}")

    def cancel_tool(self) -> None:
        if self.tool is not None and not isinstance(self.tool, HandleEditor):
            self.tool.cancel()

    def back_tool(self) -> None:
        if self.tool is not None:
            self.tool.back()

    def select_dart(self, index: int | None) -> None:
        """Select dart ``index`` (None: none): it stands out, and a curve dart's points can be dragged."""
        self.selected_dart = index
        if self.project is not None:
            self._show_darts(self.project)
        if self.dart_panel.dart_list.currentRow() != (-1 if index is None else index):
            self.dart_panel.set_project(self.project, index)
        self._refresh_handles()

    def _dart_edit(self, method, *args) -> bool:
        """One dart or yarn list edit; a refused one shows its message and the list as it was."""
        if self.document is None:
            return False
        try:
            method(*args)
        except FlatweaveError as exc:
            self.show_error(str(exc))
            self.dart_panel.set_project(self.document.project, self.selected_dart)
            return False
        return True

    def delete_dart(self, index: int) -> None:
        if self.selected_dart == index:
            self.selected_dart = None
        elif self.selected_dart is not None and self.selected_dart > index:
            self.selected_dart -= 1
        self._dart_edit(self.document.remove_dart, index)

    def edit_dart(self, index: int) -> None:
        """Edit dart ``index``: a plane dart's plane and box in the widgets; a curve dart by its points."""
        darts = self.document.project.settings.darts
        if not 0 <= index < len(darts):
            return
        if darts[index].kind == "plane":
            self.set_tool(PlaneDartTool(self, index))
        else:
            self.select_dart(index)
            self.hint("Drag the dart's points (dots) on the surface.")

    def edit_yarn(self, index: int) -> None:
        if not isinstance(self.tool, YarnTool):
            self.set_tool(YarnTool(self))
        if isinstance(self.tool, YarnTool):
            self.tool.edit(index)

    def _plane_values(self, plane, box) -> None:
        if isinstance(self.tool, PlaneDartTool):
            self.tool.set_values(plane, box)

    def _yarn_choice(self, kind, angle, k) -> None:
        if isinstance(self.tool, YarnTool):
            self.tool.set_choice(kind, angle, k)

    def dart_curve(self, surface: NurbsSurface, dart) -> np.ndarray:
        """(k, 3) a dart's curve on the surface (cached: a plane dart's takes a grid search)."""
        key = id(dart)
        hit = self._curve_cache.get(key)
        if hit is not None and hit[0] is dart and hit[1] is surface:
            return hit[2]
        uv = dart.curve_uv(surface)
        curve = surface.points(uv) if len(uv) else np.zeros((0, 3))
        if len(self._curve_cache) > 256:
            self._curve_cache.clear()
        self._curve_cache[key] = (dart, surface, curve)
        return curve

    def _show_darts(self, project: Project) -> None:
        darts = project.settings.darts
        curves = [self.dart_curve(project.surface, d) for d in darts]
        self.view.set_darts(curves, [d.visible for d in darts], self.selected_dart)

    def _yarn_polylines(self, project: Project, mesh, xyz) -> list:
        return [xyz[yarn_nodes(mesh, y.kind, y.index)] for y in project.settings.yarns]

    def _show_yarns(self, project: Project | None, frame=None) -> None:
        if project is None:
            return
        r = project.result
        if frame is not None:
            lines = self._yarn_polylines(project, frame.mesh, frame.xyz)
        elif r is not None and r.surface is project.surface:
            lines = self._yarn_polylines(project, r.mesh, r.xyz)
        else:
            lines = []
        self.view.set_yarns(lines, render=frame is None)

    # ------------------------------------------------------------------ showing
    def set_view_options(self, **changes) -> None:
        self.view_options = replace(self.view_options, **changes)
        self.view.restyle(self.view_options)
        self.pattern_view.restyle(self.view_options)

    def show_result(self, project: Project) -> None:
        """Draw the project's result (or nothing, if it has none)."""
        r = project.result
        if r is None or r.surface is not project.surface:
            self.frame = None
            self.view.clear_frame()
            self.pattern_view.clear_frame()
            self.view.render()
            self.pattern_view.render()
            self.metrics.clear()
            self.energy_plot.clear()
            return
        frame = FrameMaker(project.surface, r.settings, r.metrics.get("boundary_length_3d"),
                           r.metrics.get("area_3d")).from_result(r)
        self.pattern_view.request_fit()
        self._draw_frame(frame)
        self.energy_plot.set_history([(k + 1, e, False) for k, e in enumerate(r.history)])

    def _draw_frame(self, frame) -> None:
        self.frame = frame
        opts = self.view_options
        # Both views repaint in the same paint pass. Qt composes the whole window
        # for every pass (about 20 ms at 1600 x 1000 with software GL, whatever
        # changed), so one pass for both views is cheaper than a pass each
        # (measured with benchmarks/gui_fps.py: 16 frames/s against 9 replayed).
        self.view.show_frame(frame, opts)
        self.pattern_view.show_frame(frame, opts)
        project = self.project
        if project is not None and project.settings.yarns:
            self._show_yarns(project, frame)
        if project is not None:
            stale = frame.final and not project.result_is_current and not self.runner.busy
            self.metrics.show_frame(frame, project, stale=stale)
        if self.runner.busy:
            self.energy_plot.set_history(self.runner.history)
            self._show_progress(frame)

    def _show_progress(self, frame) -> None:
        hist = self.runner.history
        n = frame.stats.get("nodes", 0)
        paused = " - paused" if self.runner.paused else ""
        if frame.draping:
            self.progress.setText(f"Draping{paused}: {n:,} nodes laid")
            self._info_label.setText(f"draping  {n:,} nodes")
            return
        if self._first_nodes is None:
            self._first_nodes = n
        delta = ""
        if len(hist) >= 2 and hist[-2][1] > 0:
            delta = f" (change {hist[-1][1] - hist[-2][1]:+.3g})"
        text = (f"{self.runner.stage.capitalize()}{paused}: iteration {frame.iteration}, "
                f"EN {frame.energy:.6g}{delta}, {n:,} nodes ({n - self._first_nodes:+,d} since the drape)")
        self.progress.setText(text)
        self._info_label.setText(f"iteration {frame.iteration}  EN {frame.energy:.4g}  {n:,} nodes")

    def _show_hover(self, text: str | None) -> None:
        self._hover_label.setText(text or "")
        if text:
            QToolTip.showText(QCursor.pos(), text)
        else:
            QToolTip.hideText()

    # ------------------------------------------------------------------ solving
    def run(self) -> None:
        """Solve the document's project from a new drape."""
        if self.document is None:
            return
        self._rerun_timer.stop()
        self.runner.start(self.document.project)

    def rerun(self) -> None:
        """Solve again after an edit: from the last result when the drape is unchanged."""
        if self.document is None:
            return
        project = self.document.project
        self.runner.start(project, warm_start(project))

    def toggle_pause(self) -> None:
        self.runner.toggle_pause()
        if self.frame is not None and self.runner.busy:
            self._show_progress(self.frame)

    def stop(self) -> None:
        self._rerun_timer.stop()
        self.runner.stop()

    def _run_started(self, project: Project) -> None:
        self._first_nodes = None
        self.energy_plot.clear()
        if project.result is None or warm_start(project) is None:
            self.pattern_view.request_fit()
        self.progress.setText("Draping the mesh..." if warm_start(project) is None else "Starting...")
        self._update_actions()

    def _run_finished(self, outcome: RunOutcome) -> None:
        self.last_outcome = outcome
        r = outcome.result
        if r is None:
            self.progress.setText("Stopped before the first iteration; nothing changed.")
            self.show_result(self.project)
        else:
            m = r.metrics
            label = "Stop" if outcome.stopped else "Solve"
            attached = self.document.attach_result(r, outcome.source, label=label)
            if attached:
                self.energy_plot.set_history(self.runner.last_history)
                self.autosave()
                text = (f"{m.get('solver_status', 'done').capitalize()}: {m.get('iterations', 0)} iterations, "
                        f"{m.get('nodes', 0):,} nodes, EN {m.get('energy', 0):.6g}, "
                        f"{m.get('seconds', 0.0):.2f} s.")
            else:
                text = "The settings changed during the run; its result was set aside."
                self.show_result(self.project)
            self.progress.setText(text)
            self.statusBar().showMessage(text, 8000)
        self._update_actions()
        self.run_finished.emit(outcome)

    def _run_failed(self, message: str) -> None:
        self.show_error(f"Solve failed: {message}")
        self.progress.setText(f"Solve failed: {message}")
        if self.project is not None:
            self.show_result(self.project)  # back to the document's own state
        self._update_actions()
        self.run_failed.emit(message)

    def _run_cancelled(self) -> None:
        """A run was abandoned (undo, another document, ``Runner.cancel``) and none
        follows: nothing of it is kept, and views still showing its live frames
        go back to the document."""
        self.progress.setText("The run was cancelled; nothing of it was kept.")
        if self.project is not None and self.frame is not None and not self.frame.final:
            self.show_result(self.project)
        self._update_actions()

    # ------------------------------------------------------------------ errors
    def show_error(self, message: str) -> None:
        """Show a one-line error without blocking (a window-modal box, opened, not exec'd)."""
        message = " ".join(str(message).split())
        self.last_error = message
        self.statusBar().showMessage(message, 10000)
        if self.error_box is not None:
            self.error_box.close()
        box = QMessageBox(QMessageBox.Icon.Warning, "flatweave", message, QMessageBox.StandardButton.Ok, self)
        box.setAttribute(Qt.WidgetAttribute.WA_DeleteOnClose)
        box.setWindowModality(Qt.WindowModality.NonModal)
        box.finished.connect(self._error_box_finished)
        self.error_box = box
        box.show()

    def _error_box_finished(self, _result: int) -> None:
        self.error_box = None

    # ------------------------------------------------------------------ lifetime
    def showEvent(self, event) -> None:  # noqa: N802 (Qt name)
        super().showEvent(event)
        if not self._shown:
            self._shown = True  # the views have their sizes only now: frame the surface again
            QTimer.singleShot(0, self.view.reset_camera)

    def closeEvent(self, event) -> None:  # noqa: N802 (Qt name)
        if self.confirm_close and self.document is not None and self.document.unsaved_work \
                and not self._close_confirmed():
            event.ignore()
            return
        self._rerun_timer.stop()
        self._autosave_timer.stop()
        self.tool = None
        self.view.mouse_handler = None
        self.runner.shutdown()
        if self.export_thread is not None:
            self.export_thread.wait()  # atomic writes: a few seconds at most
        if self.error_box is not None:
            self.error_box.close()
        # the render windows must go before the widgets holding them are destroyed
        self._autosaver.shutdown(wait=True)
        if self.session is not None:
            self.session.close()  # a normal end: nothing to recover
            self.session = None
        self.view.close()
        self.pattern_view.close()
        super().closeEvent(event)

    def _close_confirmed(self) -> bool:
        """Ask what to do with unsaved work: Save (and close if it saved), Discard, or Cancel."""
        buttons = QMessageBox.StandardButton
        answer = QMessageBox.question(
            self, "flatweave", f"Save the changes to {self.document.project.name} before closing?",
            buttons.Save | buttons.Discard | buttons.Cancel, buttons.Save)
        if answer == buttons.Save:
            return self.save()
        return answer == buttons.Discard
