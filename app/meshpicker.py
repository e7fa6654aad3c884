"""A panel drawn on a mesh: a closed mesh (a scanned body, a last) cannot be
covered whole, one of several parts (a scan with stray pieces) needs one chosen,
and an open one far from developable (a bust open at its base) is covered
badly, so when one is opened the window shows it in a non-modal
dialog of its own (:class:`flatweave.app.view3d.MeshLoopView`) and asks for the
piece's outline: clicks on the mesh place points, the loop through them is
drawn, Backspace takes one back, and OK emits ``chosen(loop3d)``; the window
then cuts the piece out (:meth:`flatweave.reading.meshes.MeshFile.cut`, the
inside of the loop, as ``--region {"loop3d": ...}`` does) and opens it. An open
mesh can still be opened whole (``whole``). A mesh open at two ends or more (a
tube: a sleeve, a leg) can instead be opened along a seam: with "Draw a seam"
on (the picker starts so for a tube), the clicks make an open line from one
end to another, and OK emits ``seamed(seam3d)``, which the window cuts along
(:meth:`flatweave.reading.meshes.MeshFile.cut_along`, as ``--seam`` does).
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
    seamed = Signal(object)  # (k, 3) float: the seam drawn, from one open end to another
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
        self.on = on
        self.label = QLabel()
        self.seam_button = None
        if mesh.n_ends >= 2:  # a tube: opened along a seam, or a panel drawn on it
            self.seam_button = QPushButton("Draw a &seam")
            self.seam_button.setCheckable(True)
            self.seam_button.setChecked(True)
            self.seam_button.setToolTip("On: the clicks draw a seam from one open end to another, and OK opens "
                                        "the mesh along it. Off: they draw a panel's outline.")
            self.buttons.addButton(self.seam_button, QDialogButtonBox.ButtonRole.ActionRole)
            self.seam_button.toggled.connect(lambda _on: self._update())
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

    @property
    def seam(self) -> bool:
        """Whether the clicks draw a seam (an open line) rather than a panel's outline."""
        return self.seam_button is not None and self.seam_button.isChecked()

    def _update(self) -> None:
        if self.seam:
            self.label.setText(f"{self.reason}. Draw a seam on it: click points along it from one open end to "
                               f"another (a drag turns the view); OK opens it along the seam into one piece.")
        else:
            self.label.setText(f"{self.reason}. Draw the piece on {self.on}: click points round it (a drag turns "
                               f"the view); OK cuts out the inside of the loop.")
        self.view.set_loop(self.points, closed=not self.seam)
        self.ok_button.setEnabled(len(self.points) >= (2 if self.seam else 3))
        self.back_button.setEnabled(bool(self.points))

    def open_whole(self) -> None:
        super().accept()
        self.whole.emit()

    def accept(self) -> None:
        seam = self.seam
        if len(self.points) < (2 if seam else 3):
            return
        drawn = np.array(self.points)
        super().accept()
        (self.seamed if seam else self.chosen).emit(drawn)
