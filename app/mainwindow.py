"""The main window: the 3D view and the pattern view side by side, the
settings and progress dock, the metrics, menus, a toolbar and a status bar.

The window builds the widgets and puts its parts together (see
docs/ARCHITECTURE.md); each part holds one concern:

* :mod:`flatweave.app.actions`: the one table of actions, menus and toolbar, and the one
  place that enables them (:meth:`MainWindow.update_actions`);
* :mod:`flatweave.app.presenter`: document changes (as :class:`flatweave.app.aspects.Aspect`
  flags) and solve frames turned into view updates;
* :mod:`flatweave.app.files`: open, save, autosave and recovery;
* :mod:`flatweave.app.exporting`: File > Export;
* :mod:`flatweave.app.cutplanview`: the Cut plan dock (Solve > Nest pieces on the roll), a view of the
  solved pieces nested on the roll that never edits the document (the active piece's splices drawn on the
  surface by the presenter);
* :mod:`flatweave.app.runcontrol`: Run, Pause, Stop, re-runs and a run's end;
* :mod:`flatweave.app.tooling`: the 3D view's tools (one table) and the darts panel's edits.

The document is a :class:`flatweave.document.history.Document`; every user edit is one
``Document.apply``, and the window is its one listener
(:meth:`_on_document_changed`), which hands the change to its parts.
"""

from __future__ import annotations

import gc
from pathlib import Path

from PySide6.QtCore import Qt, QTimer, Signal
from PySide6.QtWidgets import (QDockWidget, QHBoxLayout, QLabel, QMainWindow, QMessageBox, QScrollArea, QSplitter,
                               QTabWidget, QToolButton, QVBoxLayout, QWidget)

from flatweave.document.history import Change, Document
from flatweave.errors import FlatweaveError
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.document.project import Project, new_project
from flatweave.document.pieces import add_from

from flatweave.app.actions import (UiState, action_specs, build_actions, build_menus, build_toolbar,
                                   show_view_choices, update_actions)
from flatweave.app.aspects import Aspect, aspects_of
from flatweave.app.cutplanview import CutPlanPanel
from flatweave.app import gcguard
from flatweave.app.dartpanel import DartPanel
from flatweave.app.exporting import Exports
from flatweave.app.files import Files, stored_view
from flatweave.app.panels import MetricsPanel, SettingsPanel
from flatweave.app.piecespanel import PiecesPanel
from flatweave.app.solveall import SolveAll
from flatweave.app.plot import EnergyPlot
from flatweave.app.presenter import Presenter
from flatweave.app.runcontrol import NO_DOCUMENT, RunControl
from flatweave.app.tooling import ToolControl, tool_specs
from flatweave.app.view2d import PatternView
from flatweave.app.view3d import SurfaceView
from flatweave.app.suggest import SuggestDialog
from flatweave.app.sweepdialog import SweepDialog

__all__ = ["MainWindow", "freeze_long_lived_objects"]

_GC_FROZEN = False


def freeze_long_lived_objects() -> None:
    """Move every object alive now (modules, Qt and VTK wrappers, the window)
    out of the cyclic garbage collector's reach, once per process: a full
    collection then walks only newer objects and no longer stalls the event
    loop (docs/decisions/0009-window-on-software-opengl.md). Objects made later are collected as usual."""
    global _GC_FROZEN
    if not _GC_FROZEN:
        _GC_FROZEN = True
        gc.collect()
        gc.freeze()


class _Part:
    """A window attribute that one of its parts holds (scripts and tests use the window's name)."""

    def __init__(self, part: str, name: str):
        self.part, self.name = part, name

    def __get__(self, window, owner=None):
        return self if window is None else getattr(getattr(window, self.part), self.name)

    def __set__(self, window, value):
        setattr(getattr(window, self.part), self.name, value)


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

    def __init__(self, parent: QWidget | None = None, recovery: bool = True):
        """``recovery``: autosave to a recovery file (see :mod:`flatweave.document.recovery`)."""
        super().__init__(parent)
        self.document: Document | None = None
        self.last_error: str | None = None  # the last error shown, one line
        self.error_box: QMessageBox | None = None
        self.last_hint: str | None = None  # the last hint a tool gave (also in the status bar)
        # ask before closing, opening or recovering over unsaved work (the launcher turns it on)
        self.confirm_close = False
        self._unsubscribe = None
        self._shown = False

        self.view = SurfaceView(self)
        self.pattern_view = PatternView(self)
        self.metrics = MetricsPanel(self)
        self.settings_panel = SettingsPanel(self)
        self.dart_panel = DartPanel(self)
        self.pieces_panel = PiecesPanel(self)
        self.solve_all = SolveAll(self)
        self.solve_panels = True  # a seam edit re-solves the other panels it changed, in Solve all's pool
        self.last_solve_all: str | None = None  # what the last Solve all did, in one line
        self.energy_plot = EnergyPlot(self)
        self.cut_plan = CutPlanPanel(self)
        self.progress = QLabel(NO_DOCUMENT, self)
        self.progress.setWordWrap(True)
        self._hover_label = QLabel(self)
        self._name_label = QLabel(self)
        self._info_label = QLabel(self)

        self.presenter = Presenter(self, self._hover_label, self._name_label, self._info_label)
        self.tools = ToolControl(self)
        self.runs = RunControl(self)
        self.files = Files(self, recovery)
        self.exports = Exports(self)

        self.action_specs = action_specs()  # the tools registered now
        self.actions = build_actions(self, self.action_specs)
        self._build_layout()
        self.menus = build_menus(self, self.actions, self.action_specs)
        self.examples_menu = self.menus["E&xamples"]
        self.files.fill_examples_menu(self.examples_menu)
        build_toolbar(self, self.actions, self.action_specs)
        self.statusBar().addWidget(self._name_label)
        self.statusBar().addWidget(self._hover_label, 1)
        self.statusBar().addPermanentWidget(self._info_label)
        self._connect()
        self.resize(1500, 920)
        self.update_actions()
        self._update_title()
        freeze_long_lived_objects()
        gcguard.acquire()  # cyclic garbage collected in this (the GUI) thread only, while the window is open
        self._gc_held = True

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
        self.side_tabs.addTab(self.pieces_panel, "Pieces")
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

        # the cut plan under the two views, hidden until asked for: a roll is long along x and wants the
        # window's width, which the side panel (a column) lacks; the settings keep the left edge's height
        self.setCorner(Qt.Corner.BottomLeftCorner, Qt.DockWidgetArea.LeftDockWidgetArea)
        self.cut_plan_dock = QDockWidget("Cut plan", self)
        self.cut_plan_dock.setObjectName("cut-plan-dock")
        self.cut_plan_dock.setWidget(self.cut_plan)
        self.cut_plan_dock.setFeatures(QDockWidget.DockWidgetFeature.DockWidgetMovable
                                       | QDockWidget.DockWidgetFeature.DockWidgetFloatable
                                       | QDockWidget.DockWidgetFeature.DockWidgetClosable)
        self.addDockWidget(Qt.DockWidgetArea.BottomDockWidgetArea, self.cut_plan_dock)
        self.cut_plan_dock.hide()

    def _connect(self) -> None:
        sp, dp, tools = self.settings_panel, self.dart_panel, self.tools
        sp.settings_edited.connect(self.edit_settings)
        sp.display_edited.connect(self.edit_display)
        sp.input_error.connect(self.show_error)
        dp.set_actions({t.panel_button: self.actions[t.key] for t in tool_specs() if t.key and t.panel_button})
        dp.dart_selected.connect(lambda row: tools.select_dart(row if row >= 0 else None))
        dp.dart_renamed.connect(lambda row, name: tools.dart_edit(self.document.rename_dart, row, name))
        dp.dart_visibility.connect(lambda row, on: tools.dart_edit(self.document.set_dart_visible, row, on))
        dp.dart_delete.connect(tools.delete_dart)
        dp.dart_edit.connect(tools.edit_dart)
        dp.editor_values.connect(tools.editor_values)
        dp.editor_apply.connect(tools.finish_tool)
        dp.editor_cancel.connect(tools.cancel_tool)
        dp.yarn_selected.connect(lambda _row: self.presenter.show_yarns(self.project))
        dp.yarn_remove.connect(lambda row: tools.dart_edit(self.document.remove_yarn, row))
        dp.yarn_edit.connect(tools.edit_yarn)
        dp.input_error.connect(self.show_error)
        dp.regions.region_edit.connect(tools.region_edit)
        self.pieces_panel.piece_selected.connect(self.select_piece)
        self.pieces_panel.piece_edit.connect(self.piece_edit)
        self.pieces_panel.solve_all.connect(self.solve_all.start)
        self.pieces_panel.add_from_file.connect(lambda: self.files.open_dialog(add=True))
        self.pieces_panel.seams.seam_delete.connect(self.remove_seam)
        self.pieces_panel.seams.seam_edit.connect(self.edit_seam)
        self.pieces_panel.seams.input_error.connect(self.show_error)
        self.solve_all.piece_done.connect(lambda name, text: self.statusBar().showMessage(
            f"Solve all: {name}: {text}", 10000))
        self.solve_all.finished.connect(self._solve_all_finished)
        self.cut_plan.finished.connect(lambda summary: self.statusBar().showMessage(summary, 20000))
        self.cut_plan.failed.connect(lambda message: self.statusBar().showMessage(f"Cut plan: {message}", 20000))
        self.cut_plan.input_error.connect(lambda message: self.statusBar().showMessage(f"Cut plan: {message}", 20000))
        self.cut_plan.plan_edited.connect(self.edit_cut_plan)  # the dock's settings are the project's cut plan
        # the active piece's splices on the surface: after a Nest, another piece active, the markers stale or gone
        self.cut_plan.splices_changed.connect(
            lambda: self.presenter.show_splices(self.project, self.cut_plan.piece_splices()))

    # ------------------------------------------------------------------ actions and title
    def update_actions(self) -> None:
        """Enable, disable and name the actions and panels for the current state (the one place that does)."""
        has_doc = self.document is not None
        update_actions(self.actions, UiState(self.document, self.runner.state, self.exports.busy, self.tools),
                       self.action_specs)
        self.settings_panel.setEnabled(has_doc)
        self.dart_panel.setEnabled(has_doc)
        self.pieces_panel.setEnabled(has_doc)
        self.pieces_panel.set_solving(self.solve_all.busy)
        self.cut_plan.setEnabled(has_doc)

    def _update_title(self) -> None:
        doc = self.document
        if doc is None:
            self.setWindowTitle("flatweave")
            return
        # "*": work that would be lost, not merely "never saved" (an untouched example has none)
        self.setWindowTitle(f"flatweave - {self.document_name}{' *' if doc.unsaved_work else ''}")

    # ------------------------------------------------------------------ the document
    @property
    def project(self) -> Project | None:
        return None if self.document is None else self.document.project

    @property
    def surface(self) -> NurbsSurface | None:
        return None if self.document is None else self.document.project.surface

    @property
    def document_name(self) -> str | None:
        """What the title and the save question call the document: its file's
        name (``saddle.flatweave``, or the surface file it was opened from),
        else the project's name."""
        doc = self.document
        if doc is None:
            return None
        return doc.path.name if doc.path is not None else doc.project.name

    @property
    def surface_name(self) -> str | None:
        return None if self.document is None else self.document.project.name

    def set_project(self, project: Project, path: str | Path | None = None, saved: bool = True) -> None:
        """Make ``project`` the document (a new history); any run is abandoned.
        ``saved=False``: it is not what ``path`` holds (a recovered autosave).
        The view choices saved with it (strain or shear, ...) are shown."""
        self.runs.abandon()
        show_view_choices(self.actions, stored_view(project))
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

    def _on_document_changed(self, project: Project, change: Change) -> None:
        aspects = aspects_of(change.aspects)  # core's strings become Aspect flags here, once
        self.runs.before_change(change.cause, aspects)
        self.presenter.document_changed(project, change.cause, aspects)
        self.cut_plan.set_project(project, change.cause)  # a marker goes stale, never edits
        self.runs.after_change(project, change.cause, aspects, change.label)
        if change.cause == "edit" and Aspect.SEAMS in aspects and Aspect.PIECES in aspects and self.solve_panels:
            # a seam edit re-solves the panels it changed (issue 42); the active one is the run's when it started one
            self.solve_all.solve_stale_panels(active=not self.runner.busy)
        self.update_actions()
        self._update_title()

    # ------------------------------------------------------------------ edits
    def _edit(self, method: str, label: str, changes: dict) -> bool:
        if self.document is None:
            return False
        try:
            getattr(self.document, method)(label, **changes)
        except (FlatweaveError, TypeError, ValueError) as exc:
            self.show_error(f"{label}: {exc}")
            self.settings_panel.set_project(self.document.project)
            return False
        return True

    def edit_settings(self, label: str, changes: dict) -> bool:
        """One undoable edit of FlattenSettings fields; refused values show an error."""
        return self._edit("edit_settings", label, changes)

    def edit_display(self, label: str, changes: dict) -> bool:
        """One undoable edit of units or shear angles."""
        return self._edit("edit_display", label, changes)

    def select_piece(self, k) -> bool:
        """Make piece ``k`` (an index or a name) the active one: the views, settings and tools show it."""
        if self.document is None:
            return False
        try:
            self.document.select_piece(k)
        except FlatweaveError as exc:
            self.show_error(str(exc))
            self.pieces_panel.set_project(self.document.project)
            return False
        return True

    def piece_edit(self, label: str, change, solves: bool) -> bool:
        """One edit of the pieces (the Pieces tab): ``change(project)`` made current as one undoable
        edit; a refused one shows its message and the list as it was."""
        if self.document is None:
            return False
        try:
            self.document.apply(label, change(self.document.project), answers_solve=solves)
        except FlatweaveError as exc:
            self.show_error(f"{label}: {exc}")
            self.pieces_panel.set_project(self.document.project)
            return False
        return True

    def remove_seam(self, sewing: str, seam: str) -> bool:
        """Delete seam ``seam`` of the shape ``sewing`` (names; the Seams list's Delete) as one undoable
        edit: the panels either side of it join. A refused one shows its message and the list as it was."""
        if self.document is None:
            return False
        try:
            self.document.remove_seam(sewing, seam)
        except FlatweaveError as exc:
            self.show_error(f"Delete {seam}: {exc}")
            self.pieces_panel.set_project(self.document.project)
            return False
        return True

    def edit_seam(self, sewing: str, seam: str, label: str, changes: dict) -> bool:
        """Change the options of seam ``seam`` of the shape ``sewing`` (names; the Seams list's Matched and
        Allowance: ``changes`` of :meth:`flatweave.document.history.Document.edit_seam`) as one undoable edit
        called ``label``. A refused one shows its message and the list as it was."""
        if self.document is None:
            return False
        try:
            self.document.edit_seam(sewing, seam, label=label, **changes)
        except FlatweaveError as exc:
            self.show_error(f"{label}: {exc}")
            self.pieces_panel.set_project(self.document.project)
            return False
        return True

    def add_pieces_from(self, project: Project) -> bool:
        """``project``'s pieces (a surface, a CAD face, a mesh's piece or a project opened to be
        added) added to the document's on their own surface, the first of them selected, as one
        undoable edit; refused (False) with its reason shown."""
        if self.document is None:
            self.set_project(project)
            return True
        names = ", ".join(p.name for p in project.pieces)
        return self.piece_edit(f"Add {names[:60]}", lambda current: add_from(current, project), False)

    def _solve_all_finished(self, summary: str) -> None:
        self.last_solve_all = summary
        self.statusBar().showMessage(summary, 20000)
        if self.document is not None:  # the sew lines' lengths read the results just attached
            self.pieces_panel.seams.set_project(self.project)
        # a result attached (cause "result") is drawn by the run that made it; Solve all's come from no
        # run of the window, so the active piece's is drawn here (not over a run of the user's under way)
        if self.document is not None and self.project.result_is_current and not self.runner.active:
            self.presenter.show_result(self.project)

    def show_cut_plan(self) -> None:
        """View > Cut plan: the Cut plan dock shown and raised (its marker as it was)."""
        if self.cut_plan_dock.isHidden():
            self.cut_plan_dock.show()
            self.resizeDocks([self.cut_plan_dock], [max(self.height() // 3, 300)], Qt.Orientation.Vertical)
        self.cut_plan_dock.raise_()

    def edit_cut_plan(self, plan, label: str) -> bool:
        """The Cut plan dock's settings edited: ``plan`` (a CutPlanSettings) made the project's cut plan as one
        undoable edit called ``label``; a refused one shows its message in one line (the dock shows the plan
        as it was)."""
        if self.document is None:
            return False
        try:
            self.document.set_cut_plan(plan, label)
        except FlatweaveError as exc:
            self.show_error(f"{label}: {exc}")
            return False
        return True

    def nest_pieces(self) -> bool:
        """Solve > Nest pieces on the roll: the Cut plan shown and a Nest started with its values
        (False when one is on already, or there is no document)."""
        if self.document is None:
            return False
        self.show_cut_plan()
        return self.cut_plan.nest()

    def undo(self) -> None:
        if self.document is not None:
            self.document.undo()

    def redo(self) -> None:
        if self.document is not None:
            self.document.redo()

    # ------------------------------------------------------------------ messages
    def hint(self, text: str) -> None:
        """A tool's hint, in the status bar."""
        self.last_hint = text
        self.statusBar().showMessage(text, 10000)

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
    def showEvent(self, event) -> None:
        super().showEvent(event)
        if not self._shown:
            self._shown = True  # the views have their sizes only now: frame the surface again
            QTimer.singleShot(0, self.view.reset_camera)

    def suggest_dialog(self):
        """Tools > Suggest darts (:mod:`flatweave.app.suggest`): one dialog at a time, non-modal."""

        if self.document is None:
            return None
        box = getattr(self, "suggest_box", None)
        if box is not None and box.isVisible():
            box.raise_()
            return box
        self.suggest_box = SuggestDialog(self)
        self.suggest_box.show()
        self.suggest_box.start()
        return self.suggest_box

    def sweep_dialog(self):
        """Solve > Best orientation (:mod:`flatweave.app.sweepdialog`): one dialog at a time, non-modal."""

        if self.document is None:
            return None
        box = getattr(self, "sweep_box", None)
        if box is not None and box.isVisible():
            box.raise_()
            return box
        self.sweep_box = SweepDialog(self)
        self.sweep_box.show()
        return self.sweep_box

    def closeEvent(self, event) -> None:
        if self.confirm_close and self.document is not None and self.document.unsaved_work \
                and not self.files.confirm_close():
            event.ignore()
            return
        self.files.stop_autosaving()
        self.solve_all.close()
        self.cut_plan.shutdown()
        self.tools.tool = None
        self.view.mouse_handler = None
        self.runs.close()
        self.exports.close()
        if self.error_box is not None:
            self.error_box.close()
        self.files.close()
        # the render windows must go before the widgets holding them are destroyed
        self.view.close()
        self.pattern_view.close()
        super().closeEvent(event)
        if self._gc_held:
            self._gc_held = False
            gcguard.release()


# The parts' names at the window's address (scripts, tests and the actions' slots use them).
_PARTS = {
    "runs": ("run", "rerun", "stop", "toggle_pause", "runner", "last_outcome"),
    "files": ("open_file", "open_example", "open_dialog", "save", "save_as", "save_to", "autosave",
              "check_recovery", "recover", "session", "recovery_box", "recovery_problem", "last_autosave",
              "autosave_failed"),
    "exports": ("export_dialog", "export_to", "export_thread", "export_box", "export_options", "last_export",
                "export_book_dialog", "export_book_to", "export_pieces_dialog", "export_pieces_to"),
    "tools": ("tool", "selected_dart", "set_tool", "finish_tool", "cancel_tool", "back_tool", "select_dart",
              "delete_dart", "edit_dart", "edit_yarn", "dart_edit"),
    "presenter": ("frame", "view_options", "set_view_options", "show_result", "dart_curve"),
}
for _part, _names in _PARTS.items():
    for _name in _names:
        setattr(MainWindow, _name, _Part(_part, _name))
del _part, _names, _name
