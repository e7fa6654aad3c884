"""A list widget as tall as its rows (the darts, yarns and regions panels)."""

from __future__ import annotations

from PySide6.QtCore import QSize
from PySide6.QtWidgets import (QListWidget)


class ShortList(QListWidget):
    """A list that asks for ``rows`` rows (a QListWidget asks for about ten):
    the side panel's scroll area sizes the dock by its parts' preferred
    heights, so two tall lists pushed the energy plot below the fold and added
    a scroll bar. It still grows into the room there is (expanding policy)."""

    def __init__(self, rows: int, parent=None):
        super().__init__(parent)
        self.rows = rows

    def sizeHint(self) -> QSize:
        h = self.rows * max(self.sizeHintForRow(0), self.fontMetrics().height() + 4) + 2 * self.frameWidth() + 4
        return QSize(super().sizeHint().width(), h)

    def minimumSizeHint(self) -> QSize:
        return QSize(super().minimumSizeHint().width(), min(self.minimumHeight() or 10**6, self.sizeHint().height()))
