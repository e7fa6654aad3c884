"""The Seams list (issue 42), in the Pieces tab under the pieces: one row per sew
line of the project's shapes split by seams (:func:`flatweave.document.checks.seam_rows`):
its name, the two panels it sews together, their two lengths in the flat (model
units, 4 significant digits; "-" for a side not solved, or solved before its last
change) and how far apart they are in percent, marked and red when over the
tolerance (:meth:`flatweave.document.sewing.SeamRow.over`: more than
``MATCH_PCT`` percent and ``MATCH_MM`` mm). Delete removes the selected row's
seam (every sew line of it; the panels either side join). Like the other panels
it never changes the document: a delete is reported as ``seam_delete(sewing,
seam)`` (the names), which the window makes one
:meth:`flatweave.document.history.Document.remove_seam`."""

from __future__ import annotations

from PySide6.QtCore import QSignalBlocker, QSize, Qt, Signal
from PySide6.QtGui import QBrush, QColor
from PySide6.QtWidgets import (QAbstractItemView, QGroupBox, QHBoxLayout, QHeaderView, QTableWidget,
                               QTableWidgetItem, QToolButton, QVBoxLayout)

from flatweave.document.checks import seam_rows
from flatweave.document.project import Project
from flatweave.document.sewing import SeamRow
from flatweave.method.seams import MATCH_MM, MATCH_PCT

__all__ = ["SeamList", "SeamTable", "seam_cells", "OVER_COLOUR"]

OVER_COLOUR = "#b00020"  # a sew line whose sides differ beyond the tolerance (the pieces list's "unusable")
OVER_MARK = "  !"
COLUMNS = (("Sew line", "The sew line: its seam's name (numbered along a seam that others meet)"),
           ("Panels", "The two panels it sews together (pieces of the project)"),
           ("Lengths", "Each side's length in the flat pattern of its panel, model units (-: not solved, or "
                       "solved before its last change)"),
           ("Difference", f"How far the two sides' lengths are apart, percent of their mean; marked when over "
                     f"{MATCH_PCT:g} % and {MATCH_MM:g} mm"))


def _length(x) -> str:
    return "-" if x is None else f"{x:#.4g}"


def seam_cells(row: SeamRow, mm_per_unit: float) -> tuple[str, str, str, str]:
    """A row's four cells as the list shows them (see the module docstring)."""
    apart = "-" if not row.solved else f"{row.difference_pct:.3f} %" + (OVER_MARK if row.over(mm_per_unit) else "")
    return row.name, " / ".join(row.panels), " / ".join(_length(x) for x in row.lengths), apart


def _tip(row: SeamRow, mm_per_unit: float, units: str) -> str:
    sides = "\n".join(f"{p}: {'not solved (or stale)' if x is None else f'{x:.6g} {units}'}"
                      for p, x in zip(row.panels, row.lengths))
    head = f"sew line {row.name!r} of seam {row.seam!r} on {row.sewing!r}\n{sides}"
    if not row.solved:
        return head
    verdict = (f"over the tolerance ({MATCH_PCT:g} % and {MATCH_MM:g} mm): the panels do not sew back together "
               "without easing" if row.over(mm_per_unit) else "within the tolerance")
    return (f"{head}\napart {row.difference:.4g} {units} ({row.difference * mm_per_unit:.3g} mm, "
            f"{row.difference_pct:.3g} %): {verdict}")


class SeamTable(QTableWidget):
    """A table that asks for ``rows`` rows (a QTableWidget asks for a fixed, tall size): the side
    panel's scroll area sizes the dock by its parts' preferred heights (see flatweave.app.shortlist)."""

    def __init__(self, rows: int, parent=None):
        super().__init__(0, len(COLUMNS), parent)
        self.rows = rows

    def sizeHint(self) -> QSize:
        row = self.verticalHeader().defaultSectionSize()
        h = (self.rows + 1) * row + 2 * self.frameWidth() + 4  # the header and the rows
        return QSize(super().sizeHint().width(), h)

    def minimumSizeHint(self) -> QSize:
        return QSize(super().minimumSizeHint().width(), self.sizeHint().height())


class SeamList(QGroupBox):
    """The Seams list (see the module docstring)."""

    seam_delete = Signal(str, str)  # the sewing's name (the shape split), the seam's name

    def __init__(self, parent=None):
        super().__init__("Seams", parent)
        self._rows: list[SeamRow] = []
        self._project: Project | None = None
        col = QVBoxLayout(self)
        self.table = SeamTable(3)
        for c, (header, tip) in enumerate(COLUMNS):
            item = QTableWidgetItem(header)
            item.setToolTip(tip)
            self.table.setHorizontalHeaderItem(c, item)
        self.table.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.table.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        self.table.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.table.verticalHeader().setVisible(False)
        self.table.setWordWrap(False)
        head = self.table.horizontalHeader()
        head.setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        head.setSectionResizeMode(1, QHeaderView.ResizeMode.Stretch)
        self.table.setToolTip("The sew lines of the seams drawn (the Seam tool): each side's length in the flat "
                              "once its panel is solved (Solve all)")
        col.addWidget(self.table)
        row = QHBoxLayout()
        self.delete = QToolButton(text="Delete")
        self.delete.setToolTip("Delete the selected sew line's seam (all its sew lines): the panels either side "
                               "join into one")
        row.addWidget(self.delete)
        row.addStretch(1)
        col.addLayout(row)
        self.delete.clicked.connect(self._delete)
        self.table.itemSelectionChanged.connect(self._update_buttons)
        self.setVisible(False)

    def _row(self) -> int | None:
        rows = self.table.selectionModel().selectedRows()
        return rows[0].row() if rows and 0 <= rows[0].row() < len(self._rows) else None

    def _delete(self) -> None:
        k = self._row()
        if k is not None:
            self.delete_row(k)

    def delete_row(self, k: int) -> None:
        """Report the delete of row ``k``'s seam (what Delete asks for the selected row)."""
        row = self._rows[k]
        self.seam_delete.emit(row.sewing, row.seam)

    # ------------------------------------------------------------------ shown
    def set_project(self, project: Project | None) -> None:
        """List ``project``'s sew lines (the row selected stays selected when its sew line is still
        listed); the list shows only when a shape is split by seams."""
        self._project = project
        picked = self._row()
        before = None if picked is None else (self._rows[picked].sewing, self._rows[picked].name)
        self._rows = seam_rows(project) if project is not None and project.sewings else []
        mm = 1000.0 * project.metres_per_unit if project is not None else 1.0
        units = project.units if project is not None else ""
        with QSignalBlocker(self.table):
            self.table.clearContents()
            self.table.setRowCount(len(self._rows))
            for r, row in enumerate(self._rows):
                tip = _tip(row, mm, units)
                over = row.over(mm)
                for c, text in enumerate(seam_cells(row, mm)):
                    item = QTableWidgetItem(text)
                    item.setToolTip(tip)
                    if c >= 2:
                        item.setTextAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
                    if over and c == 3:
                        item.setForeground(QBrush(QColor(OVER_COLOUR)))
                    self.table.setItem(r, c, item)
            again = next((r for r, row in enumerate(self._rows) if (row.sewing, row.name) == before), None)
            if again is not None:
                self.table.selectRow(again)
        self.setVisible(project is not None and bool(project.sewings))
        self._update_buttons()

    def seam_rows(self) -> list[SeamRow]:
        """The rows shown, as :func:`flatweave.document.checks.seam_rows` gave them."""
        return list(self._rows)

    def rows(self) -> list[tuple[str, ...]]:
        """The cells' texts, row by row."""
        return [tuple(self.table.item(r, c).text() for c in range(self.table.columnCount()))
                for r in range(self.table.rowCount())]

    def _update_buttons(self) -> None:
        self.delete.setEnabled(self._row() is not None)
