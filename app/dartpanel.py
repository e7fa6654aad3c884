"""The side panel of darts and yarn constraints.

:class:`DartPanel` lists the document's darts (a tick shows or hides one, its
text is its name and can be edited) and yarn constraints, and holds the
active tool's editor (:mod:`flatweave.app.tooleditors`: whichever editor class
the tool names, made here on first use). Like the settings panel it never changes
the document: it reports what the designer did through signals, and the window
turns each report into one edit (or hands it to the active tool).
"""

from __future__ import annotations


from PySide6.QtCore import QSignalBlocker, Qt, Signal
from PySide6.QtWidgets import (QAbstractItemView, QGroupBox,
                               QHBoxLayout, QListWidget, QListWidgetItem, QToolButton, QVBoxLayout, QWidget)

from flatweave.document.project import Project

from flatweave.app.tooleditors import ToolEditor
from flatweave.app.regionpanel import RegionList
from flatweave.app.shortlist import ShortList

__all__ = ["DartPanel", "yarn_label"]


def yarn_label(y) -> str:
    return f"{y.label()}  (k {y.k:g})"


class DartPanel(QWidget):
    """Darts and yarn constraints (see the module docstring)."""

    dart_selected = Signal(int)            # -1: none
    dart_renamed = Signal(int, str)
    dart_visibility = Signal(int, bool)
    dart_delete = Signal(int)
    dart_edit = Signal(int)
    yarn_selected = Signal(int)
    yarn_remove = Signal(int)
    yarn_edit = Signal(int)
    editor_values = Signal(object, dict)  # the editor, what the designer changed in it
    editor_apply = Signal()
    editor_cancel = Signal()
    input_error = Signal(str)

    def __init__(self, parent=None):
        super().__init__(parent)
        self._loading = False
        self._project: Project | None = None
        layout = QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)

        darts = QGroupBox("Darts")
        col = QVBoxLayout(darts)
        self.dart_list = ShortList(4)
        self.dart_list.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        self.dart_list.setEditTriggers(QAbstractItemView.EditTrigger.DoubleClicked
                                       | QAbstractItemView.EditTrigger.EditKeyPressed)
        self.dart_list.setToolTip("Tick to show a dart; double-click to rename it. Select a curve dart to drag "
                                  "its points on the surface")
        self.dart_list.setMinimumHeight(72)
        col.addWidget(self.dart_list)
        row = QHBoxLayout()
        self.draw_curve = QToolButton()
        self.draw_plane = QToolButton()
        # tool buttons: compact, so the row fits the dock (a push button's style minimum is wider)
        self.edit_dart = QToolButton(text="Edit")
        self.edit_dart.setToolTip("Move the selected plane dart's plane and box")
        self.delete_dart = QToolButton(text="Delete")
        for w in (self.draw_curve, self.draw_plane, self.edit_dart, self.delete_dart):
            row.addWidget(w)
        row.addStretch(1)
        col.addLayout(row)
        layout.addWidget(darts)

        yarns = QGroupBox("Constrained yarns")
        col = QVBoxLayout(yarns)
        self.yarn_list = ShortList(3)
        self.yarn_list.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        self.yarn_list.setMinimumHeight(56)
        col.addWidget(self.yarn_list)
        row = QHBoxLayout()
        self.pick_yarn = QToolButton()
        self.edit_yarn = QToolButton(text="Edit")
        self.remove_yarn = QToolButton(text="Remove")
        for w in (self.pick_yarn, self.edit_yarn, self.remove_yarn):
            row.addWidget(w)
        row.addStretch(1)
        col.addLayout(row)
        layout.addWidget(yarns)

        self._editors: dict[type, ToolEditor] = {}
        self._editor_at = layout.count()  # the tools' editors go here, below the lists
        self.regions = RegionList()
        layout.addWidget(self.regions)
        layout.addStretch(1)
        self._connect()

    BUTTONS = ("draw_curve", "draw_plane", "pick_yarn")  # the buttons a tool may name (ToolSpec.panel_button)

    def set_actions(self, actions: dict) -> None:
        """The window's tool actions on the panel's buttons: {button name (one of BUTTONS): action}."""
        for name, action in actions.items():
            if name not in self.BUTTONS:
                raise ValueError(f"the darts panel has no button {name!r} (it has {', '.join(self.BUTTONS)})")
            button = getattr(self, name)
            button.setDefaultAction(action)
            button.setToolButtonStyle(Qt.ToolButtonStyle.ToolButtonTextOnly)

    # ------------------------------------------------------------------ wiring
    def _connect(self) -> None:
        self.dart_list.currentRowChanged.connect(self._dart_row)
        self.dart_list.itemChanged.connect(self._dart_item_changed)
        self.edit_dart.clicked.connect(lambda: self._emit_row(self.dart_list, self.dart_edit))
        self.delete_dart.clicked.connect(lambda: self._emit_row(self.dart_list, self.dart_delete))
        self.yarn_list.currentRowChanged.connect(self._yarn_row)
        self.edit_yarn.clicked.connect(lambda: self._emit_row(self.yarn_list, self.yarn_edit))
        self.remove_yarn.clicked.connect(lambda: self._emit_row(self.yarn_list, self.yarn_remove))

    def _emit_row(self, widget: QListWidget, signal) -> None:
        row = widget.currentRow()
        if row >= 0:
            signal.emit(row)

    def _dart_row(self, row: int) -> None:
        if not self._loading:
            self.dart_selected.emit(row)
        self._update_buttons()

    def _yarn_row(self, row: int) -> None:
        if not self._loading:
            self.yarn_selected.emit(row)
        self._update_buttons()

    def _dart_item_changed(self, item: QListWidgetItem) -> None:
        if self._loading or self._project is None:
            return
        row = self.dart_list.row(item)
        darts = self._project.settings.darts
        if not 0 <= row < len(darts):
            return
        d = darts[row]
        visible = item.checkState() == Qt.CheckState.Checked
        if visible != d.visible:
            self.dart_visibility.emit(row, visible)
        elif item.text() != d.name:
            self.dart_renamed.emit(row, item.text())

    def _update_buttons(self) -> None:
        row = self.dart_list.currentRow()
        darts = self._project.settings.darts if self._project is not None else ()
        self.delete_dart.setEnabled(0 <= row < len(darts))
        self.edit_dart.setEnabled(0 <= row < len(darts) and darts[row].has_widget)
        yrow = self.yarn_list.currentRow()
        n = len(self._project.settings.yarns) if self._project is not None else 0
        self.edit_yarn.setEnabled(0 <= yrow < n)
        self.remove_yarn.setEnabled(0 <= yrow < n)

    # ------------------------------------------------------------------ showing
    def set_project(self, project: Project, selected: int | None = None) -> None:
        """List ``project``'s darts and yarns (without reporting edits); select dart ``selected``."""
        self._project = project
        self._loading = True
        try:
            with QSignalBlocker(self.dart_list):
                self.dart_list.clear()
                for d in project.settings.darts:
                    item = QListWidgetItem(d.name)
                    item.setFlags(item.flags() | Qt.ItemFlag.ItemIsEditable | Qt.ItemFlag.ItemIsUserCheckable)
                    item.setCheckState(Qt.CheckState.Checked if d.visible else Qt.CheckState.Unchecked)
                    item.setToolTip(f"{d.kind} dart")
                    self.dart_list.addItem(item)
                if selected is not None and 0 <= selected < len(project.settings.darts):
                    self.dart_list.setCurrentRow(selected)
            yrow = self.yarn_list.currentRow()
            with QSignalBlocker(self.yarn_list):
                self.yarn_list.clear()
                for y in project.settings.yarns:
                    self.yarn_list.addItem(yarn_label(y))
                if 0 <= yrow < len(project.settings.yarns):
                    self.yarn_list.setCurrentRow(yrow)
        finally:
            self._loading = False
        self._update_buttons()
        self.regions.set_project(project)

    def dart_names(self) -> list[str]:
        return [self.dart_list.item(k).text() for k in range(self.dart_list.count())]

    def dart_checks(self) -> list[bool]:
        return [self.dart_list.item(k).checkState() == Qt.CheckState.Checked for k in range(self.dart_list.count())]

    def editor(self, kind: type[ToolEditor]) -> ToolEditor:
        """The panel's editor of class ``kind`` (made, hidden, on first use); its
        reports come out of the panel as ``editor_values``, ``editor_apply``,
        ``editor_cancel`` and ``input_error``."""
        editor = self._editors.get(kind)
        if editor is None:
            editor = self._editors[kind] = kind(self)
            editor.hide()
            self.layout().insertWidget(self._editor_at, editor)
            editor.edited.connect(lambda values, e=editor: self.editor_values.emit(e, values))
            editor.applied.connect(self.editor_apply)
            editor.cancelled.connect(self.editor_cancel)
            editor.input_error.connect(self.input_error)
        return editor

    def shown_editors(self) -> list[ToolEditor]:
        """The editors shown now (at most the active tool's)."""
        return [e for e in self._editors.values() if not e.isHidden()]
