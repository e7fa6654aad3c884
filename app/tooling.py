"""The window's side of the 3D view's tools (:mod:`flatweave.app.tools`).

:data:`TOOLS` is the one table of the tools a designer chooses: a tool is a
:class:`~flatweave.app.tools.Tool` subclass and a row here; its action, menu entry,
toolbar button and darts-panel button come from the row (:mod:`flatweave.app.actions`).
:class:`ToolControl` keeps the active tool and the selected dart, hands the
tool the 3D view's mouse (:class:`ToolMouse`) and the keys, and turns the darts
panel's reports into document edits; tools reach the window only through
:class:`WindowToolHost`.
"""

from __future__ import annotations

from dataclasses import dataclass

from PySide6.QtWidgets import QAbstractSpinBox, QApplication, QLineEdit

from flatweave.errors import FlatweaveError

from flatweave.app.tools import CurveDartTool, HandleEditor, PlaneDartTool, RegionTool, SeedTool, Tool, YarnTool
from flatweave.app.worker import one_line

__all__ = ["ToolSpec", "TOOLS", "ToolControl", "ToolMouse", "WindowToolHost"]


@dataclass(frozen=True)
class ToolSpec:
    """A tool the designer chooses: its checkable action and the tool class it makes.

    panel_button : the darts panel's button that shows the action (see ``DartPanel.set_actions``; "": none)
    """

    key: str
    text: str
    shortcut: str
    tip: str
    tool: type[Tool]
    panel_button: str
    menu: str = "&Tools"
    toolbar: bool = True


TOOLS = (
    ToolSpec("tool_curve_dart", "&Curve dart", "D", "Draw a curve dart: click points on the surface, Enter finishes",
             CurveDartTool, "draw_curve"),
    ToolSpec("tool_plane_dart", "&Plane dart", "P", "Place a plane dart with a plane and a box, or numbers",
             PlaneDartTool, "draw_plane"),
    ToolSpec("tool_yarn", "&Yarn", "Y", "Pick a yarn to hold to a plane: click a node of the mesh",
             YarnTool, "pick_yarn"),
    ToolSpec("tool_region", "&Region", "B", "Draw the piece's boundary on the surface: click points, Enter or the "
             "first point closes; a loop inside it is a hole", RegionTool, ""),
    ToolSpec("tool_seed", "&Seed and direction", "S", "Pick the seed inside the piece (click) and the weft "
             "direction (drag from it); the rosette is drawn as two arrows", SeedTool, ""),
)


class WindowToolHost:
    """What a tool may ask of the window (the :class:`flatweave.app.tools.ToolHost` protocol)."""

    def __init__(self, window, control: ToolControl):
        self._window, self._control = window, control
        self.view = window.view
        self.editors = window.dart_panel

    @property
    def document(self):
        return self._window.document

    def hint(self, text: str) -> None:
        self._window.hint(text)

    def drop_tool(self) -> None:
        self._control.set_tool(None)

    def preview_dart(self, index: int, dart) -> None:
        self._window.runs.preview_dart(index, dart)

    def preview_settings(self, **changes) -> None:
        self._window.runs.preview_settings(**changes)

    def end_preview(self) -> None:
        self._window.runs.end_preview()


class ToolMouse:
    """The 3D view's left-button events, handed to the active tool.
    A tool's error becomes a one-line message: the view never sees it."""

    def __init__(self, control: ToolControl):
        self.control = control

    def _call(self, method: str, *args) -> bool:
        tool = self.control.tool
        if tool is None or self.control.window.document is None:
            return False
        try:
            return bool(getattr(tool, method)(*args))
        except Exception as exc:  # a tool's bug must not reach VTK's event loop
            self.control.window.show_error(f"{tool.name}: {one_line(exc)}")
            return True

    def press(self, x, y, double):
        return self._call("press", x, y, double)

    def move(self, x, y):
        return self._call("move", x, y)

    def release(self, x, y):
        return self._call("release", x, y)


class ToolControl:
    """The active tool (one at a time), the selected dart, and the darts
    panel's list edits. ``window`` gives the document, the views, the darts
    panel, ``show_error``, ``hint`` and ``update_actions``."""

    def __init__(self, window):
        self.window = window
        self.tool: Tool | None = None
        self.selected_dart: int | None = None
        self.host = WindowToolHost(window, self)
        window.view.mouse_handler = ToolMouse(self)

    def _fail(self, tool: Tool, exc: Exception) -> None:
        self.window.show_error(f"{tool.name}: {one_line(exc)}")

    # ------------------------------------------------------------------ the active tool
    def set_tool(self, tool: Tool | None) -> None:
        """Make ``tool`` the 3D view's tool (None: none; a selected curve dart's
        points can then be dragged)."""
        old, self.tool = self.tool, None
        if old is not None:
            try:
                old.deactivate()
            except Exception as exc:  # never leave the window in a half-switched state
                self._fail(old, exc)
        if tool is None:
            tool = self._handle_editor()
        self.tool = tool
        if tool is not None:
            if not tool.implied:
                self.window.side_tabs.setCurrentWidget(self.window.dart_panel)
            try:
                tool.activate()
            except Exception as exc:
                self.tool = None
                self._fail(tool, exc)
        self.window.update_actions()

    def make(self, kind: type[Tool], *args) -> Tool:
        return kind(self.host, *args)

    def toggled(self, kind: type[Tool], on: bool) -> None:
        """A tool's action was checked or unchecked."""
        if self.window.document is None:
            return
        if on and not isinstance(self.tool, kind):
            self.set_tool(self.make(kind))
        elif not on and isinstance(self.tool, kind):
            self.set_tool(None)

    def checked(self, kind: type[Tool]) -> bool:
        """Whether ``kind``'s action shows as checked."""
        return isinstance(self.tool, kind)

    def _handle_editor(self) -> HandleEditor | None:
        """The editor of the selected curve dart's points, if a curve dart is selected and shown."""
        k, doc = self.selected_dart, self.window.document
        if doc is None or k is None or k >= len(doc.project.settings.darts):
            return None
        dart = doc.project.settings.darts[k]
        return self.make(HandleEditor, k) if dart.editable_points and dart.visible else None

    def refresh_handles(self) -> None:
        if self.tool is None or self.tool.implied:
            self.set_tool(None)

    def _commit_typing(self) -> bool:
        """Enter while a field has the focus commits what was typed there (the
        field loses the focus, which ends its editing). True when Enter should
        also act on the tool: the field was the tool's own (in the darts panel)."""
        w = QApplication.focusWidget()
        if isinstance(w, (QLineEdit, QAbstractSpinBox)):
            w.clearFocus()
            return self.window.dart_panel.isAncestorOf(w)
        return True

    def finish_tool(self) -> None:
        if self.tool is not None:
            if not self._commit_typing():
                return
            try:
                self.tool.finish()
            except Exception as exc:
                self._fail(self.tool, exc)

    def cancel_tool(self) -> None:
        if self.tool is not None and not self.tool.implied:
            self.tool.cancel()

    def back_tool(self) -> None:
        if self.tool is not None:
            self.tool.back()

    def plane_values(self, plane, box) -> None:
        if self.tool is not None:
            self.tool.on_plane_values(plane, box)

    def yarn_choice(self, kind, angle, k) -> None:
        if self.tool is not None:
            self.tool.on_yarn_choice(kind, angle, k)

    def result_changed(self) -> None:
        if self.tool is not None:
            self.tool.on_result()

    # ------------------------------------------------------------------ darts and yarns
    def select_dart(self, index: int | None) -> None:
        """Select dart ``index`` (None: none): it stands out, and a curve dart's points can be dragged."""
        self.selected_dart = index
        project = self.window.project
        if project is not None:
            self.window.presenter.show_darts(project)
        if self.window.dart_panel.dart_list.currentRow() != (-1 if index is None else index):
            self.window.dart_panel.set_project(project, index)
        self.refresh_handles()

    def dart_edit(self, method, *args) -> bool:
        """One dart or yarn list edit; a refused one shows its message and the list as it was."""
        doc = self.window.document
        if doc is None:
            return False
        try:
            method(*args)
        except FlatweaveError as exc:
            self.window.show_error(str(exc))
            self.window.dart_panel.set_project(doc.project, self.selected_dart)
            return False
        return True

    def region_edit(self, label: str, change, solves: bool) -> bool:
        """One edit of the candidate regions (flatweave.app.regionpanel): ``change(project)`` made current;
        a refused one shows its message and the list as it was."""
        doc = self.window.document
        if doc is None:
            return False
        try:
            doc.apply(label, change(doc.project), answers_solve=solves)
        except FlatweaveError as exc:
            self.window.show_error(str(exc))
            self.window.dart_panel.set_project(doc.project, self.selected_dart)
            return False
        return True

    def delete_dart(self, index: int) -> None:
        if self.selected_dart == index:
            self.selected_dart = None
        elif self.selected_dart is not None and self.selected_dart > index:
            self.selected_dart -= 1
        self.dart_edit(self.window.document.remove_dart, index)

    def edit_dart(self, index: int) -> None:
        """Edit dart ``index``: a plane dart's plane and box in the widgets; a curve dart by its points."""
        darts = self.window.document.project.settings.darts
        if not 0 <= index < len(darts):
            return
        if darts[index].has_widget:
            self.set_tool(self.make(PlaneDartTool, index))
        else:
            self.select_dart(index)
            self.window.hint("Drag the dart's points (dots) on the surface.")

    def edit_yarn(self, index: int) -> None:
        if not isinstance(self.tool, YarnTool):
            self.set_tool(self.make(YarnTool))
        if isinstance(self.tool, YarnTool):
            self.tool.edit(index)

    # ------------------------------------------------------------------ the document
    def document_changed(self, cause: str, surface_or_reset: bool, lists_restored: bool) -> None:
        """A new surface or document drops the tool and the selection; undo or redo
        of a dart or yarn list edit drops the tool (its list is gone)."""
        if surface_or_reset:
            self.set_tool(None)
            self.selected_dart = None
        elif lists_restored and self.tool is not None:
            self.set_tool(None)

    def clamp_selection(self, n_darts: int) -> None:
        if self.selected_dart is not None and self.selected_dart >= n_darts:
            self.selected_dart = None
