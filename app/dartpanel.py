"""The side panel of darts and yarn constraints.

:class:`DartPanel` lists the document's darts (a tick shows or hides one, its
text is its name and can be edited) and yarn constraints, and holds the
editors of the plane dart and yarn tools (numbers for the plane and box; row or
column, angle and weight for a yarn). Like the settings panel it never changes
the document: it reports what the designer did through signals, and the window
turns each report into one edit (or hands it to the active tool).
"""

from __future__ import annotations

import math

from PySide6.QtCore import QSignalBlocker, Qt, Signal
from PySide6.QtWidgets import (QAbstractItemView, QCheckBox, QComboBox, QDoubleSpinBox, QFormLayout, QGroupBox,
                               QHBoxLayout, QLabel, QLineEdit, QListWidget, QListWidgetItem, QPushButton,
                               QToolButton, QVBoxLayout, QWidget)

from flatweave.document.project import Project

from flatweave.app.panels import NumberEdit
from flatweave.app.regionpanel import RegionList
from flatweave.app.shortlist import ShortList

__all__ = ["DartPanel", "ShortList", "parse_numbers", "format_numbers", "yarn_label"]


def parse_numbers(text: str, n: int, what: str) -> tuple[float, ...]:
    """``n`` finite numbers separated by commas, spaces or semicolons; a one-line ValueError otherwise."""
    parts = [p for p in text.replace(";", ",").replace(",", " ").split() if p]
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        raise ValueError(f"{what} must be {n} numbers, got {text.strip()!r:.60}") from None
    if len(values) != n or not all(math.isfinite(v) for v in values):
        raise ValueError(f"{what} must be {n} finite numbers, got {text.strip()!r:.60}")
    return values


def format_numbers(values) -> str:
    return ", ".join(f"{float(v):.6g}" for v in values)


def yarn_label(y) -> str:
    return f"{y.label()}  (k {y.k:g})"


class DartPanel(QWidget):
    """Darts and yarn constraints (see the module docstring)."""

    dart_selected = Signal(int)            # -1: none
    dart_renamed = Signal(int, str)
    dart_visibility = Signal(int, bool)
    dart_delete = Signal(int)
    dart_edit = Signal(int)
    plane_values = Signal(object, object)  # (a, b, c, d), box (6 numbers) or None
    plane_apply = Signal()
    plane_cancel = Signal()
    yarn_selected = Signal(int)
    yarn_remove = Signal(int)
    yarn_edit = Signal(int)
    yarn_choice = Signal(object, object, object)  # kind, angle (deg), k; None where unchanged
    yarn_apply = Signal()
    yarn_cancel = Signal()
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

        self.plane_box = QGroupBox("Plane dart")
        form = QFormLayout(self.plane_box)
        self.plane_edit = QLineEdit()
        self.plane_edit.setToolTip("The plane A x + B y + C z + D = 0")
        self.box_check = QCheckBox("only inside the box")
        self.box_edit = QLineEdit()
        self.box_edit.setToolTip("XMIN, XMAX, YMIN, YMAX, ZMIN, ZMAX")
        form.addRow("A, B, C, D", self.plane_edit)
        form.addRow(self.box_check)
        form.addRow("Box", self.box_edit)
        self.plane_status = QLabel()
        self.plane_status.setWordWrap(True)
        form.addRow(self.plane_status)
        row = QHBoxLayout()
        self.plane_apply_button = QPushButton("Apply")
        self.plane_cancel_button = QPushButton("Cancel")
        row.addWidget(self.plane_apply_button)
        row.addWidget(self.plane_cancel_button)
        row.addStretch(1)
        form.addRow(row)
        self.plane_box.hide()
        layout.addWidget(self.plane_box)

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

        self.yarn_box = QGroupBox("Yarn")
        form = QFormLayout(self.yarn_box)
        self.yarn_node = QLabel()
        self.yarn_kind = QComboBox()
        self.yarn_kind.addItem("weft row", "weft")
        self.yarn_kind.addItem("warp column", "warp")
        self.yarn_angle = QDoubleSpinBox()
        self.yarn_angle.setRange(-90.0, 90.0)
        self.yarn_angle.setDecimals(1)
        self.yarn_angle.setSingleStep(1.0)
        self.yarn_angle.setSuffix(" deg")
        self.yarn_angle.setKeyboardTracking(False)
        self.yarn_angle.setToolTip("Turn the yarn's plane about the surface normal at the picked node "
                                   "(0: through the yarn's end points)")
        self.yarn_k = NumberEdit(1000.0, 0.0)
        self.yarn_k.setToolTip("Weight k of the directional energy k/2 f^2 (f: distance to the plane)")
        form.addRow("Node", self.yarn_node)
        form.addRow("Yarn", self.yarn_kind)
        form.addRow("Plane angle", self.yarn_angle)
        form.addRow("Weight k", self.yarn_k)
        row = QHBoxLayout()
        self.yarn_apply_button = QPushButton("Apply")
        self.yarn_cancel_button = QPushButton("Cancel")
        row.addWidget(self.yarn_apply_button)
        row.addWidget(self.yarn_cancel_button)
        row.addStretch(1)
        form.addRow(row)
        self.yarn_box.hide()
        layout.addWidget(self.yarn_box)
        self.regions = RegionList()
        layout.addWidget(self.regions)
        layout.addStretch(1)
        self._connect()

    def set_actions(self, draw_curve, draw_plane, pick_yarn) -> None:
        """The window's tool actions on the panel's buttons."""
        for button, action in ((self.draw_curve, draw_curve), (self.draw_plane, draw_plane),
                               (self.pick_yarn, pick_yarn)):
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
        self.plane_edit.editingFinished.connect(self._plane_numbers)
        self.box_edit.editingFinished.connect(self._plane_numbers)
        self.box_check.toggled.connect(lambda _on: self._plane_numbers())
        self.plane_apply_button.clicked.connect(self.plane_apply)
        self.plane_cancel_button.clicked.connect(self.plane_cancel)
        self.yarn_kind.activated.connect(lambda _i: self._yarn(kind=self.yarn_kind.currentData()))
        self.yarn_angle.valueChanged.connect(lambda v: self._yarn(angle=float(v)))
        self.yarn_k.value_committed.connect(lambda v: self._yarn(k=float(v)))
        self.yarn_apply_button.clicked.connect(self.yarn_apply)
        self.yarn_cancel_button.clicked.connect(self.yarn_cancel)

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

    def _plane_numbers(self) -> None:
        if self._loading:
            return
        self.box_edit.setEnabled(self.box_check.isChecked())
        try:
            plane = parse_numbers(self.plane_edit.text(), 4, "the plane")
            box = parse_numbers(self.box_edit.text(), 6, "the box") if self.box_check.isChecked() else None
        except ValueError as exc:
            self.input_error.emit(str(exc))
            return
        self.plane_values.emit(plane, box)

    def _yarn(self, kind=None, angle=None, k=None) -> None:
        if not self._loading:
            self.yarn_choice.emit(kind, angle, k)

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

    def show_plane_editor(self, tool) -> None:
        """Show the plane dart tool's numbers (None hides the editor)."""
        if tool is None:
            self.plane_box.hide()
            return
        self._loading = True
        try:
            self.plane_box.setTitle("Plane dart" if tool.index is None else f"Plane dart: {tool.dart_name}")
            self.plane_edit.setText(format_numbers(tool.plane))
            self.box_check.setChecked(tool.box is not None)
            if tool.box is not None:
                self.box_edit.setText(format_numbers(tool.box))
            self.box_edit.setEnabled(tool.box is not None)
            n = len(tool.curve)
            self.plane_status.setText("Preview: the dart's curve on the surface (orange)." if n
                                      else "The plane does not meet the surface inside the box.")
            self.plane_apply_button.setEnabled(bool(n))
        finally:
            self._loading = False
        self.plane_box.show()

    def show_yarn_editor(self, tool) -> None:
        """Show the yarn tool's pending yarn (None, or no pending yarn, hides the editor)."""
        p = None if tool is None else tool.pending
        if p is None:
            self.yarn_box.hide()
            return
        mesh = tool.result.mesh
        i, j = (int(x) for x in mesh.ij[p.node])
        self._loading = True
        try:
            self.yarn_box.setTitle("Yarn" if p.replaces is None else f"Yarn constraint {p.replaces + 1}")
            self.yarn_node.setText(f"{p.node} at lattice ({i}, {j}); {len(tool.nodes())} nodes on the yarn")
            self.yarn_kind.setItemText(0, f"weft row {i}")
            self.yarn_kind.setItemText(1, f"warp column {j}")
            self.yarn_kind.setCurrentIndex(self.yarn_kind.findData(p.kind))
            self.yarn_kind.setEnabled(p.replaces is None)
            self.yarn_angle.setValue(p.angle_deg)
            self.yarn_k.set_value(p.k)
            self.yarn_apply_button.setEnabled(tool.plane is not None)
        finally:
            self._loading = False
        self.yarn_box.show()
