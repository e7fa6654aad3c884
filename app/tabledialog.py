"""What the project's table editors share (the materials and rosette dialogs): a
line saying what the table is, a grid with one column per ``(key, header, tip)``
and one row selected at a time, a row of tool buttons, a status line (red for a
refusal) and OK / Cancel. The subclass owns its rows, shows them
(``_show_row``) and decides what OK takes; this class only lays out and reads
the grid."""

from __future__ import annotations

from PySide6.QtCore import QSignalBlocker, Qt
from PySide6.QtWidgets import (QAbstractItemView, QDialog, QDialogButtonBox, QHBoxLayout, QHeaderView, QLabel,
                               QTableWidget, QTableWidgetItem, QToolButton, QVBoxLayout)

__all__ = ["TableDialog", "ERROR_COLOUR", "RIGHT"]

ERROR_COLOUR = "#b00020"
RIGHT = Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter  # numbers read right-aligned


class TableDialog(QDialog):
    """A dialog editing a table with ``columns`` ((key, header, tip) in order) under ``intro``.

    The subclass keeps its rows in ``_rows``, defines ``_show_row(r)`` (row ``r`` into the grid),
    ``_cell_edited(item)`` (a cell's text changed) and ``_update_buttons()`` (the selection changed),
    adds its buttons with :meth:`tool_button` and calls :meth:`_fill`."""

    def __init__(self, title: str, intro: str, columns, parent=None):
        super().__init__(parent)
        self.setWindowTitle(title)
        self.keys = tuple(key for key, _, _ in columns)
        label = QLabel(intro)
        label.setWordWrap(True)
        self.grid = QTableWidget(0, len(self.keys))
        for c, (_, header, tip) in enumerate(columns):
            item = QTableWidgetItem(header)
            item.setToolTip(tip)
            self.grid.setHorizontalHeaderItem(c, item)
        self.grid.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.grid.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        self.grid.verticalHeader().setVisible(False)
        head = self.grid.horizontalHeader()
        head.setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        head.setSectionResizeMode(0, QHeaderView.ResizeMode.Stretch)
        self.grid.itemChanged.connect(lambda item: self._cell_edited(item))
        self.grid.itemSelectionChanged.connect(lambda: self._update_buttons())
        self._tools = QHBoxLayout()
        self._tools.addStretch(1)
        self.status = QLabel("")
        self.status.setWordWrap(True)
        buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok | QDialogButtonBox.StandardButton.Cancel)
        self.ok_button = buttons.button(QDialogButtonBox.StandardButton.Ok)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        col = QVBoxLayout(self)
        col.addWidget(label)
        col.addWidget(self.grid, 1)
        col.addLayout(self._tools)
        col.addWidget(self.status)
        col.addWidget(buttons)

    def tool_button(self, text: str, tip: str, slot=None) -> QToolButton:
        """A button in the row under the table, after the ones made before; ``slot`` runs on a click."""
        button = QToolButton(text=text)
        button.setToolTip(tip)
        if slot is not None:
            button.clicked.connect(lambda _=False: slot())
        self._tools.insertWidget(self._tools.count() - 1, button)
        return button

    def cell(self, row: int, column: int) -> QTableWidgetItem:
        """The grid's item at (``row``, ``column``), made when the row is new."""
        item = self.grid.item(row, column)
        if item is None:
            item = QTableWidgetItem()
            self.grid.setItem(row, column, item)
        return item

    def _fill(self) -> None:
        """Every row shown again (the grid's own signals held), then :meth:`_refresh`."""
        with QSignalBlocker(self.grid):
            self.grid.setRowCount(len(self._rows))
            for r in range(len(self._rows)):
                self._show_row(r)
        self._refresh()

    def _refresh(self) -> None:
        """What follows a change of the rows: the buttons follow the table."""
        self._update_buttons()

    def row_texts(self) -> list[list[str]]:
        """Each row's cells as shown."""
        return [[self.grid.item(r, c).text() for c in range(len(self.keys))] for r in range(self.grid.rowCount())]

    def selected_row(self) -> int | None:
        rows = self.grid.selectionModel().selectedRows()
        return rows[0].row() if rows else None

    def select_row(self, row: int) -> None:
        self.grid.selectRow(row)

    def edit_cell(self, row: int, key: str, text: str) -> None:
        """Type ``text`` into column ``key`` of ``row``, as a cell edit does."""
        self.grid.item(row, self.keys.index(key)).setText(text)

    def _say(self, text: str, error: bool = False) -> None:
        self.status.setText(text)
        self.status.setStyleSheet(f"color: {ERROR_COLOUR}" if error else "")
