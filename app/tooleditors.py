"""The tools' editors in the darts panel: a tool names its editor class
(``Tool.editor``) and the panel makes one of each on first use
(:meth:`flatweave.app.dartpanel.DartPanel.editor`).

An editor shows what its tool holds (``show_tool``) and reports what the
designer typed or chose as a dict (``edited``), which the window hands to the
active tool as ``Tool.on_editor(values)``; Apply and Cancel are the tool's
Enter and Esc. Like every panel, an editor never changes the document.
"""

from __future__ import annotations

import math
from contextlib import contextmanager

from PySide6.QtCore import Signal
from PySide6.QtWidgets import (QCheckBox, QComboBox, QDoubleSpinBox, QFormLayout, QGroupBox, QHBoxLayout, QLabel,
                               QLineEdit, QPushButton)

from flatweave.app.panels import NumberEdit

__all__ = ["ToolEditor", "PlaneEditor", "YarnEditor", "parse_numbers", "format_numbers"]


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


class ToolEditor(QGroupBox):
    """A tool's fields in the darts panel (see the module docstring).

    edited(dict) : values the designer changed (keys are the tool's to define)
    applied, cancelled : the Apply and Cancel buttons
    input_error(str) : text that is not a value (one line)

    A subclass builds its fields in ``__init__`` (ending with ``add_buttons``)
    and fills them in ``show_tool`` inside ``with self.loading():``, so filling
    reports nothing.
    """

    edited = Signal(dict)
    applied = Signal()
    cancelled = Signal()
    input_error = Signal(str)

    def __init__(self, title: str, parent=None):
        super().__init__(title, parent)
        self._loading = False
        self.form = QFormLayout(self)

    def add_buttons(self) -> None:
        """The Apply and Cancel row, last in the form."""
        row = QHBoxLayout()
        self.apply_button = QPushButton("Apply")
        self.cancel_button = QPushButton("Cancel")
        row.addWidget(self.apply_button)
        row.addWidget(self.cancel_button)
        row.addStretch(1)
        self.form.addRow(row)
        self.apply_button.clicked.connect(self.applied)
        self.cancel_button.clicked.connect(self.cancelled)

    @contextmanager
    def loading(self):
        """A context in which changed fields report nothing."""
        self._loading = True
        try:
            yield
        finally:
            self._loading = False

    def report(self, **values) -> None:
        """Emit ``edited`` with ``values`` unless the fields are being filled."""
        if not self._loading:
            self.edited.emit(values)

    def show_tool(self, tool) -> None:
        """Fill the fields from ``tool``'s state."""
        raise NotImplementedError


class PlaneEditor(ToolEditor):
    """The plane dart tool's numbers: the plane A x + B y + C z + D = 0 and the box.
    Reports ``{"plane": (a, b, c, d), "box": (6 numbers) or None}``."""

    def __init__(self, parent=None):
        super().__init__("Plane dart", parent)
        self.plane_edit = QLineEdit()
        self.plane_edit.setToolTip("The plane A x + B y + C z + D = 0")
        self.box_check = QCheckBox("only inside the box")
        self.box_edit = QLineEdit()
        self.box_edit.setToolTip("XMIN, XMAX, YMIN, YMAX, ZMIN, ZMAX")
        self.form.addRow("A, B, C, D", self.plane_edit)
        self.form.addRow(self.box_check)
        self.form.addRow("Box", self.box_edit)
        self.status = QLabel()
        self.status.setWordWrap(True)
        self.form.addRow(self.status)
        self.add_buttons()
        self.plane_edit.editingFinished.connect(self._numbers)
        self.box_edit.editingFinished.connect(self._numbers)
        self.box_check.toggled.connect(lambda _on: self._numbers())

    def _numbers(self) -> None:
        if self._loading:
            return
        self.box_edit.setEnabled(self.box_check.isChecked())
        try:
            plane = parse_numbers(self.plane_edit.text(), 4, "the plane")
            box = parse_numbers(self.box_edit.text(), 6, "the box") if self.box_check.isChecked() else None
        except ValueError as exc:
            self.input_error.emit(str(exc))
            return
        self.report(plane=plane, box=box)

    def show_tool(self, tool) -> None:
        with self.loading():
            self.setTitle("Plane dart" if tool.index is None else f"Plane dart: {tool.dart_name}")
            self.plane_edit.setText(format_numbers(tool.plane))
            self.box_check.setChecked(tool.box is not None)
            if tool.box is not None:
                self.box_edit.setText(format_numbers(tool.box))
            self.box_edit.setEnabled(tool.box is not None)
            n = len(tool.curve)
            self.status.setText("Preview: the dart's curve on the surface (orange)." if n
                                else "The plane does not meet the surface inside the box.")
            self.apply_button.setEnabled(bool(n))


class YarnEditor(ToolEditor):
    """The yarn tool's pending yarn: its weft row or warp column, the angle of its
    plane and its weight. Reports one of ``{"kind": ...}``, ``{"angle_deg": ...}``, ``{"k": ...}``."""

    def __init__(self, parent=None):
        super().__init__("Yarn", parent)
        self.node = QLabel()
        self.kind = QComboBox()
        self.kind.addItem("weft row", "weft")
        self.kind.addItem("warp column", "warp")
        self.angle = QDoubleSpinBox()
        self.angle.setRange(-90.0, 90.0)
        self.angle.setDecimals(1)
        self.angle.setSingleStep(1.0)
        self.angle.setSuffix(" deg")
        self.angle.setKeyboardTracking(False)
        self.angle.setToolTip("Turn the yarn's plane about the surface normal at the picked node "
                              "(0: through the yarn's end points)")
        self.k = NumberEdit(1000.0, 0.0)
        self.k.setToolTip("Weight k of the directional energy k/2 f^2 (f: distance to the plane)")
        self.form.addRow("Node", self.node)
        self.form.addRow("Yarn", self.kind)
        self.form.addRow("Plane angle", self.angle)
        self.form.addRow("Weight k", self.k)
        self.add_buttons()
        self.kind.activated.connect(lambda _i: self.report(kind=self.kind.currentData()))
        self.angle.valueChanged.connect(lambda v: self.report(angle_deg=float(v)))
        self.k.value_committed.connect(lambda v: self.report(k=float(v)))

    def show_tool(self, tool) -> None:
        p = tool.pending
        mesh = tool.result.mesh
        i, j = (int(x) for x in mesh.ij[p.node])
        with self.loading():
            self.setTitle("Yarn" if p.replaces is None else f"Yarn constraint {p.replaces + 1}")
            self.node.setText(f"{p.node} at lattice ({i}, {j}); {len(tool.nodes())} nodes on the yarn")
            self.kind.setItemText(0, f"weft row {i}")
            self.kind.setItemText(1, f"warp column {j}")
            self.kind.setCurrentIndex(self.kind.findData(p.kind))
            self.kind.setEnabled(p.replaces is None)
            self.angle.setValue(p.angle_deg)
            self.k.set_value(p.k)
            self.apply_button.setEnabled(tool.plane is not None)
