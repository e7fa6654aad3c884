"""A mesh's units and fit, asked: a mesh file carries no units, so when one
opens the window takes the unit its size suggests
(:func:`flatweave.reading.meshes.guess_units`) and asks, in a non-modal dialog
showing the piece's size in each unit, whether that is right; the same dialog
shows how closely the fitted surface follows the mesh and takes a fit
tolerance (``--fit-tolerance`` on the command line). Each answer is one
undoable edit: the units a display edit, a tolerance the piece refitted
(:func:`flatweave.geometry.meshfit.mesh_surface`)."""

from __future__ import annotations

import math

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QComboBox, QDialog, QDialogButtonBox, QFormLayout, QLabel, QLineEdit, QVBoxLayout

from flatweave.document.project import UNITS
from flatweave.geometry.meshfit import FIT_TOL

__all__ = ["MeshDialog"]


class MeshDialog(QDialog):
    """Which unit one coordinate of ``name`` is (``guess`` preselected), and
    the fit tolerance wanted for ``fit`` (a :class:`flatweave.geometry.meshfit.MeshFit`).
    OK emits ``chosen(unit)``, then ``refit(tolerance)`` when a tolerance is
    given that differs from the fit's own; a tolerance that is not a positive
    number is said in the dialog, which stays open."""

    chosen = Signal(str)
    refit = Signal(float)

    def __init__(self, name: str, fit, guess: str, parent=None):
        super().__init__(parent)
        self.fit = fit
        size = fit.size
        self.setWindowTitle(f"flatweave: units and fit of {name}")
        self.setWindowModality(Qt.WindowModality.NonModal)
        self.setAttribute(Qt.WidgetAttribute.WA_DeleteOnClose)
        self.label = QLabel(f"{name} carries no units. It is {size:.4g} units across; its size suggests "
                            f"{guess}. Which unit is one coordinate?")
        self.label.setWordWrap(True)
        self.units = QComboBox()
        for unit, metres in UNITS.items():
            self.units.addItem(f"{unit}: the piece is {size * metres:.3g} m across", unit)
        self.units.setCurrentIndex(self.units.findData(guess))
        self.fit_label = QLabel(fit.describe())
        self.fit_label.setWordWrap(True)
        self.tolerance = QLineEdit("" if fit.tolerance is None else f"{fit.tolerance:g}")
        self.tolerance.setPlaceholderText(f"default: {FIT_TOL * size:.3g} ({100 * FIT_TOL:g} % of its size), "
                                          f"as near as its vertices allow")
        self.tolerance.setToolTip("The largest distance wanted from a vertex of the mesh to the fitted surface, "
                                  "in model units; the surface is refitted until it holds, or says why not")
        self.error = QLabel("")
        self.error.setStyleSheet("color: #b00020")
        form = QFormLayout()
        form.addRow("Units", self.units)
        form.addRow("Fit tolerance", self.tolerance)
        buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok)
        buttons.accepted.connect(self.accept)
        layout = QVBoxLayout(self)
        layout.addWidget(self.label)
        layout.addWidget(self.fit_label)
        layout.addLayout(form)
        layout.addWidget(self.error)
        layout.addWidget(buttons)

    def tolerance_value(self) -> float | None:
        """The tolerance typed (model units), None when left empty; ValueError when not a positive number."""
        text = self.tolerance.text().strip()
        if not text:
            return None
        value = float(text)
        if not (math.isfinite(value) and value > 0):
            raise ValueError(text)
        return value

    def accept(self) -> None:
        try:
            tolerance = self.tolerance_value()
        except ValueError:
            self.error.setText(f"The fit tolerance must be a positive length in model units, not "
                               f"{self.tolerance.text().strip()!r}")
            return
        unit = self.units.currentData()
        super().accept()
        self.chosen.emit(unit)
        if tolerance is not None and tolerance != self.fit.tolerance:
            self.refit.emit(tolerance)
