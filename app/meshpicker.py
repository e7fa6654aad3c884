"""A panel drawn on a mesh: a closed mesh (a scanned body, a last) cannot be
covered whole, one of several parts (a scan with stray pieces) needs one chosen,
and an open one far from developable (a bust open at its base) is covered
badly, so when one is opened the window shows it in a non-modal
dialog of its own (:class:`flatweave.app.view3d.MeshLoopView`) and asks for the
piece's outline: clicks on the mesh place points, the loop through them is
drawn, Backspace takes one back, and OK emits ``chosen(loop3d)``; the window
then cuts the piece out (:meth:`flatweave.reading.meshes.MeshFile.cut`, the
inside of the loop, as ``--region {"loop3d": ...}`` does) and opens it. An open
mesh can still be opened whole (``whole``).
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
    whole = Signal()  # open the mesh as one piece after all

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
        mesh = opened.mesh
        on = "it"
        if mesh.needs_region:
            self.reason = mesh.needs_region.split(":")[0]  # why the picker is shown, one clause
        elif mesh.n_parts > 1:
            self.reason, on = f"{name} has {mesh.n_parts} separate parts", "one of them"
        else:
            self.reason = mesh.advice.split(":")[0]
        self.label = QLabel(f"{self.reason}. Draw the piece on {on}: click points round it (a drag turns the "
                            f"view); OK cuts out the inside of the loop.")
        self.whole_button = None
        if opened.surface is not None:  # open: it can be covered whole, if badly
            self.whole_button = QPushButton("Open it &whole")
            self.buttons.addButton(self.whole_button, QDialogButtonBox.ButtonRole.ActionRole)
            self.whole_button.clicked.connect(self.open_whole)
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

    def open_whole(self) -> None:
        super().accept()
        self.whole.emit()

    def accept(self) -> None:
        if len(self.points) < 3:
            return
        loop = np.array(self.points)
        super().accept()
        self.chosen.emit(loop)
