"""Solve > Best orientation: :func:`flatweave.studies.sweep.sweep` on the document's piece,
in a thread of its own; the ranked table (a usable pattern first, each row
saying whether its pattern is usable and why not), a plot of the largest
shear against the weft angle, and Apply, which sets the chosen row's angle and seed as one
undoable settings edit (the window then solves it as after any such edit).
"""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import QPointF, QSize
from PySide6.QtGui import QColor, QPainter, QPen, QPolygonF
from PySide6.QtWidgets import (QDialog, QDialogButtonBox, QHBoxLayout, QLabel, QPushButton, QSpinBox,
                               QTableWidget, QTableWidgetItem, QVBoxLayout, QWidget)

from flatweave.app.background import BackgroundCall
from flatweave.studies.sweep import warm_pool
from flatweave.studies.sweep import sweep

__all__ = ["SweepDialog", "ShearPlot", "COLUMNS"]

COLUMNS = (("angle_deg", "weft angle", "{:.2f}"), ("seed", "seed", None),
           ("area_beyond_lock_pct", "beyond lock %", "{:.3f}"), ("max_shear_deg", "max shear deg", "{:.2f}"),
           ("boundary_error_pct", "boundary %", "{:.3f}"), ("area_error_pct", "area %", "{:.3f}"),
           ("nodes", "nodes", "{}"), ("unusable", "pattern", None))


class ShearPlot(QWidget):
    """The largest shear (degrees) against the weft angle; the best row marked."""

    def __init__(self, parent=None):
        super().__init__(parent)
        self.angles = np.zeros(0)
        self.shear = np.zeros(0)
        self.best: float | None = None
        self.setMinimumHeight(120)
        self.setToolTip("Largest shear against weft angle (the best row marked in orange)")

    def sizeHint(self) -> QSize:
        return QSize(420, 140)

    def set_rows(self, rows, best=None) -> None:
        ok = [r for r in rows if not r.get("error")]
        order = np.argsort([r["angle_deg"] for r in ok]) if ok else []
        self.angles = np.array([ok[k]["angle_deg"] for k in order], dtype=float)
        self.shear = np.array([ok[k]["max_shear_deg"] for k in order], dtype=float)
        self.best = None if best is None else float(best["angle_deg"])
        self.update()

    def points(self) -> list[tuple[float, float]]:
        """The plotted points in widget pixels, in angle order."""
        if len(self.angles) == 0:
            return []
        m = 28.0
        w, h = max(self.width() - 2 * m, 1.0), max(self.height() - 2 * m, 1.0)
        a0, a1 = float(self.angles.min()), float(self.angles.max())
        s0, s1 = float(self.shear.min()), float(self.shear.max())
        sa, ss = (a1 - a0) or 1.0, (s1 - s0) or 1.0
        return [(m + (a - a0) / sa * w, m + h - (s - s0) / ss * h) for a, s in zip(self.angles, self.shear)]

    def paintEvent(self, _event) -> None:
        p = QPainter(self)
        p.fillRect(self.rect(), QColor("white"))
        pts = self.points()
        p.setPen(QColor("#222222"))
        p.drawText(6, 16, "max shear (deg) against weft angle (deg)")
        if pts:
            p.drawText(6, self.height() - 6, f"{self.angles.min():.0f}")
            p.drawText(self.width() - 40, self.height() - 6, f"{self.angles.max():.0f}")
            p.drawText(self.width() - 90, 16, f"{self.shear.min():.1f} .. {self.shear.max():.1f}")
            p.setPen(QPen(QColor("#1f5fa8"), 2))
            p.drawPolyline(QPolygonF([QPointF(x, y) for x, y in pts]))
            if self.best is not None:
                k = int(np.argmin(np.abs(self.angles - self.best)))
                p.setPen(QPen(QColor("#e08a00"), 2))
                p.setBrush(QColor("#e08a00"))
                p.drawEllipse(QPointF(*pts[k]), 4, 4)
        p.end()


class SweepDialog(QDialog):
    def __init__(self, window):
        super().__init__(window)
        self.setWindowTitle("Best orientation")
        self.window_ = window
        self.project = window.document.project
        self.result = None
        self.call = BackgroundCall(self._done, self)
        lay = QVBoxLayout(self)
        row = QHBoxLayout()
        row.addWidget(QLabel("Angles"))
        self.angles = QSpinBox(minimum=2, maximum=72, value=12)
        row.addWidget(self.angles)
        row.addWidget(QLabel("seeds"))
        self.seeds = QSpinBox(minimum=1, maximum=6, value=1)
        row.addWidget(self.seeds)
        self.go = QPushButton("Sweep")
        self.go.clicked.connect(self.start)
        row.addWidget(self.go)
        row.addStretch(1)
        lay.addLayout(row)
        self.status = QLabel("")
        self.status.setWordWrap(True)  # the ranking rule and a reason are sentences
        lay.addWidget(self.status)
        self.table = QTableWidget(0, len(COLUMNS))
        self.table.setHorizontalHeaderLabels([c[1] for c in COLUMNS])
        self.table.setSelectionBehavior(QTableWidget.SelectionBehavior.SelectRows)
        self.table.setSelectionMode(QTableWidget.SelectionMode.SingleSelection)
        self.table.setEditTriggers(QTableWidget.EditTrigger.NoEditTriggers)
        lay.addWidget(self.table)
        self.plot = ShearPlot()
        lay.addWidget(self.plot)
        self.buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Apply | QDialogButtonBox.StandardButton.Close)
        self.apply_button = self.buttons.button(QDialogButtonBox.StandardButton.Apply)
        self.apply_button.clicked.connect(self.apply)
        self.apply_button.setEnabled(False)
        self.buttons.rejected.connect(self.close)
        lay.addWidget(self.buttons)
        self.resize(720, 460)
        warm_pool()  # the workers import the solver while the user picks the angles, not during the sweep

    @property
    def busy(self) -> bool:
        return self.call.busy

    def start(self) -> None:
        if self.busy:
            return
        project = self.window_.document.project
        self.project = project
        angles, seeds = self.angles.value(), self.seeds.value()
        self.go.setEnabled(False)
        self.apply_button.setEnabled(False)
        self.status.setText(f"Solving at {angles} angles x {seeds} seed{'s' if seeds > 1 else ''}...")

        self.call.start(lambda: sweep(project.surface, project.settings, angles=angles, seeds=seeds), "sweep")

    def _done(self, result, error) -> None:
        self.go.setEnabled(True)
        if error is not None:
            self.status.setText(f"No sweep: {error}")
            return
        self.result = result
        rows = result.rows
        self.table.setRowCount(len(rows))
        for i, r in enumerate(rows):
            for j, (key, _title, fmt) in enumerate(COLUMNS):
                if key == "seed":
                    text = f"{r['seed'][0]:.3f}, {r['seed'][1]:.3f}"
                elif key == "unusable" and not r.get("error"):
                    text = "not usable: " + ", ".join(r["unusable"]) if r.get("unusable") else "usable"
                elif r.get("error"):
                    text = "failed" if j == 2 else ""
                else:
                    text = fmt.format(r[key])
                self.table.setItem(i, j, QTableWidgetItem(text))
        self.plot.set_rows(rows, result.best)
        self.table.selectRow(0)
        self.apply_button.setEnabled(True)
        best = result.best
        none = ("; no angle gives a usable pattern (" + ", ".join(best["unusable"]) + ")"
                if best.get("unusable") else "")
        self.status.setText(f"Best: weft angle {best['angle_deg']:.2f} deg ({len(rows)} solves, "
                            f"{result.seconds:.1f} s){none}; ranked by the pattern's usability (no metric "
                            "past its bad limit) first, then the area beyond the lock angle, the largest "
                            "shear and the boundary error.")

    def chosen(self) -> dict | None:
        if self.result is None:
            return None
        sel = self.table.selectionModel().selectedRows()
        return self.result.rows[sel[0].row() if sel else 0]

    def apply(self) -> None:
        row = self.chosen()
        doc = self.window_.document
        if row is None or doc is None or row.get("error"):
            return
        doc.edit_settings(f"Weft angle {row['angle_deg']:.4g} deg (best orientation)",
                          angle_deg=float(row["angle_deg"]), seed=tuple(float(x) for x in row["seed"]))
        self.accept()
