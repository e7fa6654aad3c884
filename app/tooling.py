"""The window's side of the 3D view's tools (:mod:`flatweave.app.tools`).

The tools are one registry (:func:`register_tool`, :func:`tool_specs`): a tool
is a :class:`~flatweave.app.tools.Tool` subclass and one :class:`ToolSpec`; its
action, menu entry, toolbar button and darts-panel button come from the spec
(:func:`flatweave.app.actions.action_specs`, read when a window is made), its
overlay layers and its editor from the class. :class:`ToolControl` keeps the
active tool and the selected dart, hands the tool the 3D view's mouse
(:class:`ToolMouse`), the keys and its editor's reports, clears its layers and
hides its editor when it ends, and turns the darts panel's reports into
document edits; tools reach the window only through :class:`WindowToolHost`.
Below the registry nothing here, in the window or in the views names a
particular tool.
"""

from __future__ import annotations

from dataclasses import dataclass

from PySide6.QtWidgets import QAbstractSpinBox, QApplication, QLineEdit

from flatweave.errors import FlatweaveError

from flatweave.app.tools import (CurveDartTool, HandleEditor, NotchTool, PlaneDartTool, RegionTool, SeamTool, SeedTool,
                                 Tool, YarnTool)
from flatweave.app.worker import one_line

__all__ = ["ToolSpec", "register_tool", "unregister_tool", "tool_specs", "ToolControl", "ToolMouse",
           "WindowToolHost"]


@dataclass(frozen=True)
class ToolSpec:
    """A registered tool: the tool class and, when ``key`` is set, the checkable
    action that makes it (an ``implied`` tool, made for the selection, has none).

    key, text, shortcut, tip : the action's key (``window.actions[key]``), menu
        text, shortcut ("": none) and tip
    panel_button : the darts panel's button that shows the action (one of
        ``DartPanel.BUTTONS``; "": none)
    menu : the menu the action sits in; toolbar : whether the toolbar shows it
    """

    key: str
    text: str
    shortcut: str
    tip: str
    tool: type[Tool]
    panel_button: str
    menu: str = "&Tools"
    toolbar: bool = True


_TOOLS: list[ToolSpec] = [
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
    ToolSpec("tool_seam", "&Seam", "E", "Draw a seam from edge to edge: click points on the surface, Enter "
             "finishes; the piece splits into panels that sew back together", SeamTool, ""),
    ToolSpec("tool_notch", "&Notch", "N", "Notch a seam: click on a seam to put a notch there (both panels get one "
             "in the cut files), click a notch to remove it", NotchTool, ""),
    ToolSpec("", "", "", "", HandleEditor, "", toolbar=False),
]


def register_tool(spec: ToolSpec) -> None:
    """Add a tool (after those registered); a window made afterwards offers it.
    A key already registered is refused (ValueError)."""
    if not isinstance(spec, ToolSpec) or not (isinstance(spec.tool, type) and issubclass(spec.tool, Tool)):
        raise TypeError("register_tool takes a ToolSpec whose tool is a Tool subclass")
    if spec.key and any(t.key == spec.key for t in _TOOLS):
        raise ValueError(f"a tool with key {spec.key!r} is registered already")
    if not spec.key and not spec.tool.implied:
        raise ValueError(f"{spec.tool.__name__} needs an action key: only an implied tool goes without one")
    _TOOLS.append(spec)


def unregister_tool(key_or_class) -> None:
    """Remove the tool registered under this action key (or with this tool class)."""
    _TOOLS[:] = [t for t in _TOOLS if t.key != key_or_class and t.tool is not key_or_class]


def tool_specs() -> tuple[ToolSpec, ...]:
    """The registered tools, in order."""
    return tuple(_TOOLS)


class WindowToolHost:
    """What a tool may ask of the window (the :class:`flatweave.app.tools.ToolHost` protocol)."""

    def __init__(self, window, control: ToolControl):
        self._window, self._control = window, control
        self.view = window.view

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

    def show_editor(self, tool: Tool) -> None:
        if tool.editor is not None and tool is self._control.tool:
            editor = self._window.dart_panel.editor(tool.editor)
            editor.show_tool(tool)
            editor.show()

    def hide_editor(self, tool: Tool) -> None:
        if tool.editor is not None:
            self._window.dart_panel.editor(tool.editor).hide()


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
            old.clear_drawing()  # what a tool drew and its editor end with it
            old.hide_editor()
        if tool is None:
            tool = self._implied_tool()
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

    @staticmethod
    def editing_tool(item: str, implied: bool) -> type[Tool] | None:
        """The registered tool class that edits items of kind ``item`` ("plane dart", "yarn", ...),
        among the implied tools or the chosen ones; None when none does."""
        for spec in tool_specs():
            if item in spec.tool.edits and spec.tool.implied == implied:
                return spec.tool
        return None

    def _implied_tool(self) -> Tool | None:
        """The tool the selected dart implies (a curve dart's points to drag), if any."""
        k, doc = self.selected_dart, self.window.document
        if doc is None or k is None or k >= len(doc.project.settings.darts):
            return None
        kind = self.editing_tool(f"{doc.project.settings.darts[k].kind} dart", implied=True)
        return self.make(kind, k) if kind is not None and kind.wants(doc, k) else None

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

    def editor_values(self, editor, values: dict) -> None:
        """An editor's report goes to the active tool if the editor is that tool's
        (a field left as another tool starts reports to nobody)."""
        tool = self.tool
        if tool is not None and tool.editor is not None and type(editor) is tool.editor:
            try:
                tool.on_editor(values)
            except Exception as exc:
                self._fail(tool, exc)

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
        """The darts panel's Edit on dart ``index``: see ``edit``."""
        darts = self.window.document.project.settings.darts
        if 0 <= index < len(darts):
            self.edit(f"{darts[index].kind} dart", index)

    def edit_yarn(self, index: int) -> None:
        self.edit("yarn", index)

    def edit(self, item: str, index: int) -> None:
        """Edit item ``index`` of kind ``item``: with the chosen tool that edits such items
        (made unless active, then ``edit(index)``); else, for a dart, by selecting it
        (an implied tool edits it, a curve dart's points say)."""
        kind = self.editing_tool(item, implied=False)
        if kind is None:
            if item.endswith(" dart"):
                self.select_dart(index)  # the implied tool, if any, says what to drag
            return
        if type(self.tool) is not kind:
            self.set_tool(self.make(kind))
        if type(self.tool) is kind:
            try:
                self.tool.edit(index)
            except Exception as exc:
                self._fail(self.tool, exc)

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
