"""The face picker: which face of a STEP or IGES file with several faces to open.

A non-modal dialog lists the file's faces (index, kind, area, trimmed) and
shows them all in a 3D view of its own (:class:`flatweave.app.view3d.FaceView`), each
face's surface sampled on a (u, v) grid and cut to its trimmed region
(:func:`face_mesh`). A click on a face in the view or a row of the list
chooses it (the others are drawn faint); a shift-click (in the view or the
list) adds a face to the choice, or takes it out again. OK emits
``chosen(index)`` for one face, ``joined(indices)`` for several: the window
joins them into one surface (:func:`flatweave.reading.cadjoin.join_faces`), so that a piece
can cross a fillet.
"""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import (QAbstractItemView, QDialog, QDialogButtonBox, QHBoxLayout, QLabel,
                               QListWidget, QListWidgetItem, QVBoxLayout)

from flatweave.geometry.region import region_from_cad_face

from flatweave.app.presenter import piece_grid
from flatweave.app.view3d import FaceView

__all__ = ["FacePicker", "face_mesh", "face_label", "PICK_GRID"]

PICK_GRID = 40  # (u, v) samples a side of each face's mesh


def face_mesh(face, n: int = PICK_GRID) -> tuple[np.ndarray, np.ndarray]:
    """A CAD face (:class:`flatweave.reading.cad.CadFace`) as a triangle mesh on its
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


class ViewDialog(QDialog):
    """A dialog that owns a render view (``self.view``): the view closes with it,
    however it ends (OK, Cancel, the window's close button)."""

    view = None

    def done(self, result: int) -> None:
        if self.view is not None:
            self.view.close()
        super().done(result)

    def closeEvent(self, event) -> None:
        if self.view is not None:
            self.view.close()
        super().closeEvent(event)


class FacePicker(ViewDialog):
    """Choose a face of ``opened`` (a :class:`flatweave.reading.registry.Opened` with
    ``cad``), or several to join. On OK ``chosen(index)`` is emitted with one
    face chosen, ``joined(indices)`` (a tuple, in the order they were chosen)
    with several; the dialog deletes itself when it closes."""

    chosen = Signal(int)
    joined = Signal(tuple)

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
        self.list.setSelectionMode(QAbstractItemView.SelectionMode.ExtendedSelection)
        self.list.itemSelectionChanged.connect(self._rows_changed)
        self._faces: list[int] = []
        self.buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok | QDialogButtonBox.StandardButton.Cancel)
        self.buttons.accepted.connect(self.accept)
        self.buttons.rejected.connect(self.reject)
        self.ok_button = self.buttons.button(QDialogButtonBox.StandardButton.Ok)
        self.ok_button.setEnabled(False)
        side = QVBoxLayout()
        side.addWidget(QLabel(f"{len(cad.faces)} faces: click one in the view or choose it here;\n"
                              f"shift-click adds faces that join it into one piece."))
        side.addWidget(self.list)
        top = QHBoxLayout()
        top.addWidget(self.view.widget, 3)
        top.addLayout(side, 2)
        layout = QVBoxLayout(self)
        layout.addLayout(top)
        layout.addWidget(self.buttons)
        self.view.on_pick = self._picked
        self.view.set_faces([face_mesh(f) for f in cad.faces])

    @property
    def face(self) -> int | None:
        """The face chosen now (None before any; the first when there are several)."""
        return self._faces[0] if self._faces else None

    @property
    def faces(self) -> tuple[int, ...]:
        """Every face chosen now, in the order they were chosen."""
        return tuple(self._faces)

    def select(self, index: int | None, add: bool = False) -> None:
        """Choose face ``index`` alone, or with ``add`` add it to the faces
        chosen (take it out when it is one of them)."""
        if add and index is not None:
            faces = [k for k in self._faces if k != index] if index in self._faces else self._faces + [int(index)]
        else:
            faces = [] if index is None else [int(index)]
        self._set_faces(faces)

    def _set_faces(self, faces: list[int]) -> None:
        self._faces = faces
        self.view.select(faces[0] if faces else None, also=faces)
        self.ok_button.setEnabled(bool(faces))
        self.ok_button.setText("Join and open" if len(faces) > 1 else "OK")
        self.list.blockSignals(True)
        for row in range(self.list.count()):
            self.list.item(row).setSelected(row in faces)
        if faces:
            self.list.setCurrentRow(faces[-1], self.list.selectionModel().SelectionFlag.NoUpdate)
        self.list.blockSignals(False)
        self.list.viewport().update()

    def _picked(self, index: int) -> None:
        self.select(index, add=self.view.shift_pick)

    def _rows_changed(self) -> None:
        rows = {self.list.row(item) for item in self.list.selectedItems()}
        kept = [k for k in self._faces if k in rows]  # the order they were chosen in, then the new ones
        self._set_faces(kept + sorted(rows - set(kept)))

    def accept(self) -> None:
        faces = self.faces
        if not faces:
            return
        super().accept()
        if len(faces) == 1:
            self.chosen.emit(faces[0])
        else:
            self.joined.emit(faces)
