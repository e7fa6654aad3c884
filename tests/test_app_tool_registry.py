"""A tool registered with one call is a tool of the window like the built-in
ones: its action, menu entry and toolbar button; the 3D view's mouse; its own
overlay layer and editor in the darts panel, both gone when it ends; its
commit one undoable edit. Nothing else is touched (ARCHITECTURE, "A GUI tool")."""

from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtWidgets import QLineEdit, QToolBar

from flatweave.app.overlay import LayerStyle
from flatweave.app.tooleditors import ToolEditor
from flatweave.app.tooling import ToolSpec, register_tool, tool_specs, unregister_tool
from flatweave.app.tools import Tool, pick_surface
from tests.test_app_tools import CAMERA, click, pixel, ready

PIN = np.array([0.6, 0.55, 0.58]) / np.linalg.norm([0.6, 0.55, 0.58])  # a point on the octant


class AngleEditor(ToolEditor):
    """One field: the weft angle the pin tool will set (degrees)."""

    def __init__(self, parent=None):
        super().__init__("Pin", parent)
        self.angle = QLineEdit()
        self.form.addRow("Weft angle", self.angle)
        self.add_buttons()
        self.angle.editingFinished.connect(self._typed)

    def _typed(self):
        try:
            self.report(angle=float(self.angle.text()))
        except ValueError:
            self.input_error.emit(f"the angle must be a number, got {self.angle.text()!r}")

    def show_tool(self, tool):
        with self.loading():
            self.angle.setText(f"{tool.angle:g}")


class PinTool(Tool):
    """A toy: a click pins a point (a green marker); the editor's angle, applied, becomes the weft angle."""

    name = "pin"
    layers = {"pin": LayerStyle("#00c000", size=15.0)}
    editor = AngleEditor

    def __init__(self, host):
        super().__init__(host)
        self.angle, self.pinned = 0.0, None

    def press(self, x, y, double):
        hit = pick_surface(self.surface, self.view, x, y)
        if hit is None:
            return False
        self.pinned = hit[1]
        self.draw("pin", points=self.pinned)
        self.show_editor()
        return True

    def on_editor(self, values):
        self.angle = values["angle"]

    def finish(self):
        if self.pinned is None:
            return False
        doc = self.document
        doc.apply("Pin the weft angle", doc.project.with_settings(angle_deg=self.angle))
        self.host.drop_tool()
        return True


@pytest.fixture
def pin_tool():
    register_tool(ToolSpec("tool_pin", "P&in", "Ctrl+Shift+I", "Pin a point; set the weft angle", PinTool, ""))
    yield
    unregister_tool("tool_pin")


def test_a_registered_tool_is_offered_draws_edits_and_cleans_up(pin_tool, make_window, qtbot):
    win = make_window()
    action = win.actions["tool_pin"]
    assert action in win.menus["&Tools"].actions() and action in win.findChild(QToolBar).actions()
    assert action.shortcut().toString() == "Ctrl+Shift+I"
    win.view.look(*CAMERA)
    ready(qtbot, win)
    action.trigger()
    assert isinstance(win.tool, PinTool) and action.isChecked()
    assert win.dart_panel.shown_editors() == []  # nothing pinned yet
    click(qtbot, win.view, *pixel(win.view, PIN))
    drawn = win.view.layer_points("pin")
    assert drawn.shape == (1, 3) and np.linalg.norm(drawn[0] - PIN) < 0.01  # under the cursor, on the surface
    look = win.view.layer_look("pin")
    assert look["size"] == 15.0 and look["fill"] == pytest.approx((0.0, 192 / 255, 0.0), abs=1e-3)
    editor = win.dart_panel.editor(AngleEditor)
    assert win.dart_panel.shown_editors() == [editor] and editor.angle.text() == "0"
    editor.angle.setText("30")
    editor.angle.editingFinished.emit()
    assert win.tool.angle == 30.0
    win.actions["tool_finish"].trigger()
    assert win.project.settings.angle_deg == 30.0 and win.document.undo_label == "Pin the weft angle"
    assert win.tool is None and not action.isChecked()
    assert len(win.view.layer_points("pin")) == 0 and win.dart_panel.shown_editors() == []


def test_an_editor_reports_only_to_its_own_tool(pin_tool, make_window, qtbot):
    win = make_window()
    editor = win.dart_panel.editor(AngleEditor)
    win.actions["tool_curve_dart"].trigger()  # a tool with another editor (none)
    editor.angle.setText("12")
    editor.angle.editingFinished.emit()  # a field left behind: reported to nobody, and nothing fails
    assert win.last_error in (None, "") and win.project.settings.angle_deg == 0.0


def test_the_tool_registry_refuses_what_it_cannot_offer(pin_tool, make_window):
    with pytest.raises(ValueError, match="tool_pin"):
        register_tool(ToolSpec("tool_pin", "Again", "", "", PinTool, ""))
    with pytest.raises(ValueError, match="action key"):
        register_tool(ToolSpec("", "", "", "", PinTool, ""))
    with pytest.raises(TypeError):
        register_tool(ToolSpec("tool_x", "X", "", "", object, ""))
    with pytest.raises(ValueError, match="no button"):
        make_window(example=None).dart_panel.set_actions({"nowhere": None})
    unregister_tool("tool_pin")
    assert all(t.key != "tool_pin" for t in tool_specs())
    assert "tool_pin" not in make_window(example=None).actions
