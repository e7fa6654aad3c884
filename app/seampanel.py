"""The Seams list (issue 42), in the Pieces tab under the pieces: one row per sew
line of the project's shapes split by seams (:func:`flatweave.document.checks.seam_rows`):
its name; Matched, its seam's option (a checkbox: the next Solve all solves the two
panels to equal sides, :mod:`flatweave.document.matching`); how far apart its two
sides' lengths in the flat are in percent, marked and red when over the tolerance
(:meth:`flatweave.document.sewing.SeamRow.over`: more than ``MATCH_PCT`` percent
and ``MATCH_MM`` mm; "-" while a side is not solved, or solved before its last
change); after a matched solve what matching cost (the energy EN the two panels
gained over their energy solved alone, "+2e-06"; "-" otherwise); its seam's allowance in mm
("default": the export's; a double click types it); the two panels it sews
together and their two lengths in the flat (model units, 4 significant digits).
What the designer reads and changes comes first, as the side panel is narrow and
the table scrolls sideways. The options are the seam's: every sew line of a seam
(a seam met by others is cut into "NAME 1", "NAME 2", ...) shows the same. The
table is as tall as its rows, from 3 to 6. Delete removes the selected row's
seam (every sew line of it; the panels either side join). Like the other panels
it never changes the document: a delete is reported as ``seam_delete(sewing,
seam)`` (the names), which the window makes one
:meth:`flatweave.document.history.Document.remove_seam`, an option changed as
``seam_edit(sewing, seam, label, changes)`` (``changes``: ``{"matched": bool}`` or
``{"allowance_mm": mm or None}``), one :meth:`flatweave.document.history.Document.edit_seam`;
an allowance it cannot read is ``input_error(message)`` (one line), the cell shown
as it was."""

from __future__ import annotations

import math

from PySide6.QtCore import QSignalBlocker, QSize, Qt, Signal
from PySide6.QtGui import QBrush, QColor
from PySide6.QtWidgets import (QAbstractItemView, QGroupBox, QHBoxLayout, QHeaderView, QTableWidget,
                               QTableWidgetItem, QToolButton, QVBoxLayout)

from flatweave.document.checks import seam_rows
from flatweave.document.project import Project
from flatweave.document.sewing import MAX_ALLOWANCE_MM, SeamLine, SeamRow
from flatweave.method.seams import MATCH_MM, MATCH_PCT

__all__ = ["SeamList", "SeamTable", "seam_cells", "read_allowance", "OVER_COLOUR", "MATCHED", "DIFFERENCE", "COST",
           "ALLOWANCE", "PANELS", "LENGTHS"]

OVER_COLOUR = "#b00020"  # a sew line whose sides differ beyond the tolerance (the pieces list's "unusable")
OVER_MARK = "  !"
DEFAULT = "default"  # an allowance left to the export's
COLUMNS = (("Sew line", "The sew line: its seam's name (numbered along a seam that others meet)"),
           ("Matched", "Solve the seam's two panels so its sides come out equal in length (at the next Solve "
                       "all): a constraint across the seam, paid for in the panels' strain (see Cost)"),
           ("Difference", f"How far the two sides' lengths are apart, percent of their mean; marked when over "
                     f"{MATCH_PCT:g} % and {MATCH_MM:g} mm"),
           ("Cost", "After a matched Solve all: the two panels' energy over their energy solved alone "
                    "(unmatched), percent; -: not solved matched"),
           ("Allowance", f"The seam allowance along the seam in the cut files, mm ({DEFAULT}: the export's); "
                         f"double-click to type it, 0 to {MAX_ALLOWANCE_MM:g}, empty for the export's"),
           ("Panels", "The two panels it sews together (pieces of the project)"),
           ("Lengths", "Each side's length in the flat pattern of its panel, model units (-: not solved, or "
                       "solved before its last change)"))
MATCHED, DIFFERENCE, COST, ALLOWANCE, PANELS, LENGTHS = range(1, len(COLUMNS))  # the columns after the name
ROWS = (3, 6)  # the table's height, in rows: as many as it has, within these


def _length(x) -> str:
    return "-" if x is None else f"{x:#.4g}"


def _cost(cost: float | None) -> str:
    # the energy EN added (the units the window's numbers give the energy in), not its percentage: a panel
    # nearly developable lies near rest alone, so a negligible cost is hundreds of percent of its energy
    return "-" if cost is None else f"{cost:+.2g}"


def _allowance(seam: SeamLine | None) -> str:
    return DEFAULT if seam is None or seam.allowance_mm is None else f"{seam.allowance_mm:g} mm"


def seam_cells(row: SeamRow, mm_per_unit: float, seam: SeamLine | None = None) -> tuple[str, ...]:
    """A row's seven cells as the list shows them, in the order of COLUMNS (see the module docstring);
    ``seam`` is the row's seam, whose allowance it shows (None: the default). The Matched cell's text is
    empty (its checkbox says it)."""
    apart = "-" if not row.solved else f"{row.difference_pct:.3f} %" + (OVER_MARK if row.over(mm_per_unit) else "")
    return (row.name, "", apart, _cost(row.energy_cost), _allowance(seam), " / ".join(row.panels),
            " / ".join(_length(x) for x in row.lengths))


def read_allowance(text: str) -> float | None:
    """A typed seam allowance: mm from 0 to MAX_ALLOWANCE_MM ("mm" after it allowed), None for empty or
    "default" (the export's); a one-line ValueError otherwise."""
    t = text.strip().casefold().removesuffix("mm").strip()
    if t in ("", DEFAULT):
        return None
    try:
        mm = float(t)
    except ValueError:
        mm = math.nan
    if not 0.0 <= mm <= MAX_ALLOWANCE_MM:  # NaN and infinities too
        raise ValueError(f"{text.strip()!r:.40} is not a seam allowance: type 0 to {MAX_ALLOWANCE_MM:g} mm, or "
                         "nothing for the export's")
    return mm


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


def _option_tip(row: SeamRow, column: int) -> str:
    """The tooltip of row ``row``'s cell in the Matched, Cost or Allowance column."""
    if column == MATCHED:
        return (f"seam {row.seam!r}: " + ("its two sides are solved to equal lengths (Solve all)" if row.matched
                                          else "its panels are solved alone") + "; click to change")
    if column == ALLOWANCE:
        return f"seam {row.seam!r}'s seam allowance in the cut files; double-click to type mm, empty for the export's"
    if row.energy_cost is None:
        return (f"{' and '.join(row.panels)}: not solved matched (the energy cost of matching shows after a "
                "Solve all with the seam matched)")
    pct = "" if row.energy_cost_pct is None else f", {row.energy_cost_pct:+.3g} % of it"
    return (f"{' and '.join(row.panels)}: matching {'raised' if row.energy_cost >= 0 else 'lowered'} their energy "
            f"EN by {abs(row.energy_cost):.3g} over their energy solved alone (unmatched){pct}")


class SeamTable(QTableWidget):
    """A table that asks for ``rows`` rows (a QTableWidget asks for a fixed, tall size) and its
    horizontal scroll bar, which it shows when its columns are wider than the side panel: the side
    panel's scroll area sizes the dock by its parts' preferred heights (see flatweave.app.shortlist).
    Set ``rows`` and call ``updateGeometry`` to change it."""

    def __init__(self, rows: int, parent=None):
        super().__init__(0, len(COLUMNS), parent)
        self.rows = rows

    def sizeHint(self) -> QSize:
        row = self.verticalHeader().defaultSectionSize()
        bar = self.horizontalScrollBar().sizeHint().height()  # always counted: the height stays as it is
        h = (self.rows + 1) * row + bar + 2 * self.frameWidth() + 4  # the header, the rows and the scroll bar
        return QSize(super().sizeHint().width(), h)

    def minimumSizeHint(self) -> QSize:
        return QSize(super().minimumSizeHint().width(), self.sizeHint().height())


class SeamList(QGroupBox):
    """The Seams list (see the module docstring)."""

    seam_delete = Signal(str, str)  # the sewing's name (the shape split), the seam's name
    seam_edit = Signal(str, str, str, dict)  # the sewing's name, the seam's, the edit's label, the changes
    input_error = Signal(str)  # an allowance the list cannot read (one line)

    def __init__(self, parent=None):
        super().__init__("Seams", parent)
        self._rows: list[SeamRow] = []
        self._seams: dict[tuple[str, str], SeamLine] = {}  # (sewing, seam) -> the seam, for its options
        self._project: Project | None = None
        col = QVBoxLayout(self)
        self.table = SeamTable(ROWS[0])
        for c, (header, tip) in enumerate(COLUMNS):
            item = QTableWidgetItem(header)
            item.setToolTip(tip)
            self.table.setHorizontalHeaderItem(c, item)
        self.table.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.table.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        # only the Allowance cells are editable (their flags); the Matched checkbox takes a click
        self.table.setEditTriggers(QAbstractItemView.EditTrigger.DoubleClicked
                                   | QAbstractItemView.EditTrigger.EditKeyPressed)
        self.table.verticalHeader().setVisible(False)
        self.table.setWordWrap(False)
        self.table.setHorizontalScrollMode(QAbstractItemView.ScrollMode.ScrollPerPixel)
        head = self.table.horizontalHeader()
        head.setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        self.table.setToolTip("The sew lines of the seams drawn (the Seam tool): each side's length in the flat "
                              "once its panel is solved (Solve all), and the seam's options")
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
        self.table.itemChanged.connect(self._item_changed)
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

    def _item_changed(self, item: QTableWidgetItem) -> None:
        """A Matched checkbox clicked or an Allowance typed: reported when it changes the seam."""
        r, c = item.row(), item.column()
        if not 0 <= r < len(self._rows) or c not in (MATCHED, ALLOWANCE):
            return
        row = self._rows[r]
        seam = self._seams.get((row.sewing, row.seam))
        if c == MATCHED:
            on = item.checkState() == Qt.CheckState.Checked
            if on != row.matched:
                self.seam_edit.emit(row.sewing, row.seam, f"{'Match' if on else 'Unmatch'} {row.seam}",
                                    {"matched": on})
            return
        try:
            mm = read_allowance(item.text())
        except ValueError as exc:
            self.input_error.emit(f"Seam allowance of {row.seam}: {exc}")
            mm = None if seam is None else seam.allowance_mm  # shown as it was
        else:
            if seam is not None and mm != seam.allowance_mm:
                self.seam_edit.emit(row.sewing, row.seam, f"Seam allowance of {row.seam}", {"allowance_mm": mm})
                return
        with QSignalBlocker(self.table):
            item.setText(DEFAULT if mm is None else f"{mm:g} mm")

    # ------------------------------------------------------------------ shown
    def set_project(self, project: Project | None) -> None:
        """List ``project``'s sew lines (the row selected stays selected when its sew line is still
        listed); the list shows only when a shape is split by seams."""
        self._project = project
        picked = self._row()
        before = None if picked is None else (self._rows[picked].sewing, self._rows[picked].name)
        self._rows = seam_rows(project) if project is not None and project.sewings else []
        self._seams = {} if project is None else {(s.name, x.name): x for s in project.sewings for x in s.seams}
        mm = 1000.0 * project.metres_per_unit if project is not None else 1.0
        units = project.units if project is not None else ""
        fixed = Qt.ItemFlag.ItemIsSelectable | Qt.ItemFlag.ItemIsEnabled
        with QSignalBlocker(self.table):
            self.table.clearContents()
            self.table.setRowCount(len(self._rows))
            for r, row in enumerate(self._rows):
                tip = _tip(row, mm, units)
                over = row.over(mm)
                for c, text in enumerate(seam_cells(row, mm, self._seams.get((row.sewing, row.seam)))):
                    item = QTableWidgetItem(text)
                    item.setFlags(fixed)
                    item.setToolTip(_option_tip(row, c) if c in (MATCHED, COST, ALLOWANCE) else tip)
                    if c in (DIFFERENCE, COST, ALLOWANCE, LENGTHS):
                        item.setTextAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
                    if over and c == DIFFERENCE:
                        item.setForeground(QBrush(QColor(OVER_COLOUR)))
                    if c == MATCHED:
                        item.setFlags(fixed | Qt.ItemFlag.ItemIsUserCheckable)
                        item.setCheckState(Qt.CheckState.Checked if row.matched else Qt.CheckState.Unchecked)
                    elif c == ALLOWANCE:
                        item.setFlags(fixed | Qt.ItemFlag.ItemIsEditable)
                    self.table.setItem(r, c, item)
            again = next((r for r, row in enumerate(self._rows) if (row.sewing, row.name) == before), None)
            if again is not None:
                self.table.selectRow(again)
        rows = min(max(len(self._rows), ROWS[0]), ROWS[1])
        if rows != self.table.rows:
            self.table.rows = rows
            self.table.updateGeometry()
        self.setVisible(project is not None and bool(project.sewings))
        self._update_buttons()

    def seam_rows(self) -> list[SeamRow]:
        """The rows shown, as :func:`flatweave.document.checks.seam_rows` gave them."""
        return list(self._rows)

    def rows(self) -> list[tuple[str, ...]]:
        """The cells' texts, row by row (the Matched cell's is empty: see :meth:`matched`)."""
        return [tuple(self.table.item(r, c).text() for c in range(self.table.columnCount()))
                for r in range(self.table.rowCount())]

    def matched(self) -> list[bool]:
        """The Matched checkboxes, row by row."""
        return [self.table.item(r, MATCHED).checkState() == Qt.CheckState.Checked
                for r in range(self.table.rowCount())]

    def _update_buttons(self) -> None:
        self.delete.setEnabled(self._row() is not None)
