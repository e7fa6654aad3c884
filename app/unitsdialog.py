"""The units of a mesh, asked: a mesh file carries none, so when one opens
the window takes the unit its size suggests
(:func:`flatweave.reading.meshes.guess_units`) and asks, in a non-modal dialog
showing the piece's size in each unit, whether that is right. The choice is
one display edit (undoable, saved with the project)."""

from __future__ import annotations

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QComboBox, QDialog, QDialogButtonBox, QLabel, QVBoxLayout

from flatweave.document.project import UNITS

__all__ = ["UnitsDialog"]


class UnitsDialog(QDialog):
    """Which unit one coordinate of ``name`` (``size`` units across) is; ``guess`` preselected."""

    chosen = Signal(str)

    def __init__(self, name: str, size: float, guess: str, parent=None):
        super().__init__(parent)
        self.setWindowTitle(f"flatweave: units of {name}")
        self.setWindowModality(Qt.WindowModality.NonModal)
        self.setAttribute(Qt.WidgetAttribute.WA_DeleteOnClose)
        self.label = QLabel(f"{name} carries no units. It is {size:.4g} units across; its size suggests "
                            f"{guess}. Which unit is one coordinate?")
        self.label.setWordWrap(True)
        self.units = QComboBox()
        for unit, metres in UNITS.items():
            self.units.addItem(f"{unit}: the piece is {size * metres:.3g} m across", unit)
        self.units.setCurrentIndex(self.units.findData(guess))
        buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok)
        buttons.accepted.connect(self.accept)
        layout = QVBoxLayout(self)
        layout.addWidget(self.label)
        layout.addWidget(self.units)
        layout.addWidget(buttons)

    def accept(self) -> None:
        unit = self.units.currentData()
        super().accept()
        self.chosen.emit(unit)
