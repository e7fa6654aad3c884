"""The region of a closed mesh: a mesh with no boundary (a scanned body, a
last) cannot be covered whole, so when one is opened the window shows it in a
non-modal dialog of its own (:class:`flatweave.app.view3d.MeshLoopView`) and asks for
the piece's outline: clicks on the mesh place points, the loop through them is
drawn, Backspace takes one back, and OK emits ``chosen(loop3d)``; the window
then cuts the piece out (:meth:`flatweave.geometry.meshfit.MeshFile.cut`, the smaller side
of the loop, as ``--region {"loop3d": ...}`` does) and opens it.
"""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import Qt, Signal
from PySide6.QtGui import QKeySequence, QShortcut
from PySide6.QtWidgets import QDialogButtonBox, QLabel, QPushButton, QVBoxLayout

from flatweave.app.facepicker import ViewDialog
from flatweave.app.view3d import MeshLoopView

__all__ = ["MeshLoopPicker"]


class MeshLoopPicker(ViewDialog):
    """Draw the piece's outline on ``opened``'s closed mesh (a
    :class:`flatweave.reading.registry.Opened` with ``mesh``); the dialog deletes itself
    when it closes."""

    chosen = Signal(object)  # (k, 3) float: the loop drawn

    def __init__(self, opened, parent=None):
        super().__init__(parent)
        self.opened = opened
        name = opened.path.name if opened.path is not None else "the mesh"
        self.setWindowTitle(f"flatweave: draw the piece on {name}")
        self.setWindowModality(Qt.WindowModality.NonModal)
        self.setAttribute(Qt.WidgetAttribute.WA_DeleteOnClose)
        self.resize(800, 620)
        self.points: list[np.ndarray] = []
        self.view = MeshLoopView(self)
        self.buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok | QDialogButtonBox.StandardButton.Cancel)
        self.back_button = QPushButton("Take &back a point")
        self.buttons.addButton(self.back_button, QDialogButtonBox.ButtonRole.ActionRole)
        self.back_button.clicked.connect(self.take_back)
        QShortcut(QKeySequence("Backspace"), self, self.take_back)
        self.buttons.accepted.connect(self.accept)
        self.buttons.rejected.connect(self.reject)
        self.ok_button = self.buttons.button(QDialogButtonBox.StandardButton.Ok)
        self.label = QLabel(f"{name} is a closed mesh: draw the piece on it. Click points round it (a drag turns "
                            f"the view); OK cuts out the smaller side of the loop.")
        self.label.setWordWrap(True)
        layout = QVBoxLayout(self)
        layout.addWidget(self.label)
        layout.addWidget(self.view.widget, 1)
        layout.addWidget(self.buttons)
        self.view.on_point = self.add_point
        self.view.set_mesh(opened.mesh.vertices, opened.mesh.triangles)
        self._update()

    def add_point(self, xyz) -> None:
        """Place a point of the loop (a click on the mesh does this)."""
        self.points.append(np.asarray(xyz, dtype=float).reshape(3))
        self._update()

    def take_back(self) -> None:
        if self.points:
            self.points.pop()
            self._update()

    def _update(self) -> None:
        self.view.set_loop(self.points)
        self.ok_button.setEnabled(len(self.points) >= 3)
        self.back_button.setEnabled(bool(self.points))

    def accept(self) -> None:
        if len(self.points) < 3:
            return
        loop = np.array(self.points)
        super().accept()
        self.chosen.emit(loop)
