"""A small energy-versus-iteration plot drawn with QPainter (no plotting library).

The energy axis is logarithmic (a solve spans many decades); iterations where
the population changed (nodes deleted or refilled) are marked with ticks.
"""

from __future__ import annotations

import math

import numpy as np
from PySide6.QtCore import QPointF, QRectF, QSize, Qt
from PySide6.QtGui import QColor, QFont, QPainter, QPen, QPolygonF
from PySide6.QtWidgets import QSizePolicy, QWidget

__all__ = ["EnergyPlot", "NO_SOLVE", "result_note"]

LINE = QColor("#1f5fa8")
CHANGE = QColor("#e08a00")
GRID = QColor("#dddddd")
TEXT = QColor("#222222")
MIN_HEIGHT = 120  # pixels: the title, the axis labels and a readable curve
NO_SOLVE = "no solve yet"


def result_note(metrics: dict) -> str:
    """What the plot says of a result whose trace has no point to draw: how its solve
    ended and after how many iterations ("converged at the start: 0 iterations")."""
    n = metrics.get("iterations", 0)
    status = str(metrics.get("solver_status", "done"))
    if status == "converged" and n == 0:
        status = "converged at the start"
    return f"{status}: {n} iteration{'' if n == 1 else 's'}"


class EnergyPlot(QWidget):
    """EN against iteration; :meth:`set_history` with (iteration, energy, changed) rows."""

    def __init__(self, parent=None):
        super().__init__(parent)
        self.iterations = np.zeros(0)
        self.energies = np.zeros(0)
        self.changes = np.zeros(0, dtype=bool)
        self.note = NO_SOLVE  # what the plot says when it has no point to draw
        self.text_rects: list = []
        self.setMinimumHeight(MIN_HEIGHT)
        self.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Preferred)
        self.setToolTip("Energy EN (log scale) against iteration; orange ticks: nodes deleted or refilled")

    def sizeHint(self) -> QSize:
        return QSize(300, 150)

    def clear(self) -> None:
        self.set_history([])

    def set_history(self, history, note: str = NO_SOLVE) -> None:
        """history: sequence of (iteration, energy, population changed); ``note``: what the
        plot says when none of it can be drawn (a result's :func:`result_note`)."""
        if note != self.note:
            self.note = note
            self.update()
        if len(history) == len(self.iterations) and len(history) and history[-1][0] == self.iterations[-1]:
            return
        rows = list(history)
        self.iterations = np.array([r[0] for r in rows], dtype=float)
        self.energies = np.array([r[1] for r in rows], dtype=float)
        self.changes = np.array([bool(r[2]) for r in rows], dtype=bool)
        self.update()

    def paintEvent(self, _event) -> None:
        self.text_rects = []  # (text, QRectF it took) of every text drawn, for the layout tests
        painter = QPainter(self)
        painter.setRenderHint(QPainter.RenderHint.Antialiasing)
        painter.fillRect(self.rect(), QColor("white"))
        font = QFont(self.font())
        font.setPointSizeF(max(7.0, font.pointSizeF() * 0.85))
        painter.setFont(font)
        fm = painter.fontMetrics()
        left, right, top, bottom = fm.horizontalAdvance("1e-10 ") + 4, 8, 2 * fm.height(), fm.height() + 6
        plot = QRectF(left, top, max(10, self.width() - left - right), max(10, self.height() - top - bottom))
        painter.setPen(QPen(GRID, 1))
        painter.drawRect(plot)
        painter.setPen(TEXT)
        self._text(painter, QRectF(4, 2, plot.width() * 0.55, fm.height()), Qt.AlignmentFlag.AlignLeft,
                   "energy EN (log)")
        ok = np.isfinite(self.energies) & (self.energies > 0)
        if ok.sum() < 1:
            note = self.note
            if len(self.energies) and note == NO_SOLVE:  # a trace, but no energy a log axis can show
                note = f"EN {self.energies[-1]:.4g}: not on a log scale"
            self._text(painter, plot, Qt.AlignmentFlag.AlignCenter, note)
            painter.end()
            return
        it, en = self.iterations[ok], np.log10(self.energies[ok])
        x0, x1 = float(it.min()), float(max(it.max(), it.min() + 1))
        y0, y1 = math.floor(en.min()), math.ceil(en.max())
        if y1 <= y0:
            y1 = y0 + 1
        # decade grid lines
        for d in range(int(y0), int(y1) + 1):
            y = plot.bottom() - (d - y0) / (y1 - y0) * plot.height()
            painter.setPen(QPen(GRID, 1))
            painter.drawLine(QPointF(plot.left(), y), QPointF(plot.right(), y))
            if d in (y0, y1) or (y1 - y0) <= 4:
                painter.setPen(TEXT)
                box = QRectF(0, y - fm.height() / 2, left - 3, fm.height())
                box.moveTop(min(max(box.top(), 0.0), self.height() - fm.height()))  # the end labels stay inside
                self._text(painter, box, Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter, f"1e{d}")
        xs = plot.left() + (it - x0) / (x1 - x0) * plot.width()
        ys = plot.bottom() - (en - y0) / (y1 - y0) * plot.height()
        painter.setPen(QPen(CHANGE, 1))
        for x in xs[self.changes[ok]]:
            painter.drawLine(QPointF(x, plot.bottom()), QPointF(x, plot.bottom() - 6))
        painter.setPen(QPen(LINE, 1.6))
        if len(xs) == 1:
            painter.drawEllipse(QPointF(xs[0], ys[0]), 2, 2)
        else:
            painter.drawPolyline(QPolygonF([QPointF(x, y) for x, y in zip(xs, ys)]))
        painter.setPen(TEXT)
        self._text(painter, QRectF(plot.left(), plot.bottom() + 2, plot.width(), fm.height()),
                   Qt.AlignmentFlag.AlignLeft, f"{int(x0)}")
        self._text(painter, QRectF(plot.left(), plot.bottom() + 2, plot.width(), fm.height()),
                   Qt.AlignmentFlag.AlignRight, f"iteration {int(it.max())}")
        self._text(painter, QRectF(plot.left() + plot.width() * 0.45, 2, plot.width() * 0.55 - 2, fm.height()),
                   Qt.AlignmentFlag.AlignRight, f"EN {self.energies[ok][-1]:.4g}")
        painter.end()

    def _text(self, painter: QPainter, box: QRectF, flags, text: str) -> None:
        self.text_rects.append((text, painter.boundingRect(box, flags, text)))
        painter.drawText(box, flags, text)
