"""The face picker: which face of a STEP or IGES file with several faces to open.

A non-modal dialog lists the file's faces (index, kind, area, trimmed) and
shows them all in a 3D view of its own (:class:`app.view3d.FaceView`), each
face's surface sampled on a (u, v) grid and cut to its trimmed region
(:func:`face_mesh`). A click on a face in the view or a row of the list
chooses it (the others are drawn faint); OK emits ``chosen(index)``.
"""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import (QDialog, QDialogButtonBox, QHBoxLayout, QLabel, QListWidget,
                               QListWidgetItem, QVBoxLayout)

from core.region import region_from_cad_face

from app.presenter import piece_grid
from app.view3d import FaceView

__all__ = ["FacePicker", "face_mesh", "face_label", "PICK_GRID"]

PICK_GRID = 40  # (u, v) samples a side of each face's mesh


def face_mesh(face, n: int = PICK_GRID) -> tuple[np.ndarray, np.ndarray]:
    """A CAD face (:class:`core.cad.CadFace`) as a triangle mesh on its
    surface: points (n*n, 3) and triangles (m, 3), the grid's quads whose
    centres lie in the face's trimmed region, two triangles each."""
    _, xyz, _, keep, _ = piece_grid(face.surface, region_from_cad_face(face), n)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    quads = np.stack([a, b, c, d], axis=-1).reshape(-1, 4)
    if keep is not None:
        quads = quads[keep.ravel()]
    tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    return xyz.reshape(-1, 3), tris


def face_label(face, units: str = "") -> str:
    """A list row: "3  bspline  area 812.4 mm²  trimmed"."""
    unit = f" {units}²" if units else ""
    return f"{face.index}  {face.kind}  area {face.area:.4g}{unit}  {'trimmed' if face.trimmed else 'untrimmed'}"


class FacePicker(QDialog):
    """Choose one face of ``opened`` (a :class:`core.readers.Opened` with
    ``cad``). ``chosen(index)`` is emitted on OK with a face chosen; the dialog
    deletes itself when it closes."""

    chosen = Signal(int)

    def __init__(self, opened, parent=None):
        super().__init__(parent)
        self.opened = opened
        cad = opened.cad
        name = opened.path.name if opened.path is not None else "the file"
        self.setWindowTitle(f"flatweave: choose a face of {name}")
        self.setWindowModality(Qt.WindowModality.NonModal)
        self.setAttribute(Qt.WidgetAttribute.WA_DeleteOnClose)
        self.resize(900, 560)
        self.view = FaceView(self)
        self.list = QListWidget(self)
        for face in cad.faces:
            item = QListWidgetItem(face_label(face, cad.units))
            item.setData(Qt.ItemDataRole.UserRole, face.index)
            self.list.addItem(item)
        self.list.currentRowChanged.connect(self._row_changed)
        self.buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok | QDialogButtonBox.StandardButton.Cancel)
        self.buttons.accepted.connect(self.accept)
        self.buttons.rejected.connect(self.reject)
        self.ok_button = self.buttons.button(QDialogButtonBox.StandardButton.Ok)
        self.ok_button.setEnabled(False)
        side = QVBoxLayout()
        side.addWidget(QLabel(f"{len(cad.faces)} faces: click one in the view or choose it here."))
        side.addWidget(self.list)
        top = QHBoxLayout()
        top.addWidget(self.view.widget, 3)
        top.addLayout(side, 2)
        layout = QVBoxLayout(self)
        layout.addLayout(top)
        layout.addWidget(self.buttons)
        self.view.on_pick = self.select
        self.view.set_faces([face_mesh(f) for f in cad.faces])

    @property
    def face(self) -> int | None:
        """The face chosen now (None before any)."""
        return self.view.chosen

    def select(self, index: int | None) -> None:
        """Choose face ``index`` (a click in the view or the list does this)."""
        self.view.select(index)
        self.ok_button.setEnabled(index is not None)
        row = -1 if index is None else int(index)
        if self.list.currentRow() != row:
            self.list.blockSignals(True)
            self.list.setCurrentRow(row)
            self.list.blockSignals(False)

    def _row_changed(self, row: int) -> None:
        self.select(None if row < 0 else row)

    def accept(self) -> None:
        index = self.face
        if index is None:
            return
        super().accept()
        self.chosen.emit(index)

    def done(self, result: int) -> None:
        self.view.close()
        super().done(result)

    def closeEvent(self, event) -> None:
        self.view.close()
        super().closeEvent(event)
