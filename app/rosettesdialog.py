"""The tool's rosettes, edited (issue 41, item 1): a dialog over a copy of a
project's rosette table (:attr:`flatweave.document.project.Project.rosettes`,
rows :class:`flatweave.document.rosettes.ToolRosette`). One row per rosette:
its name, its origin x, y, z, its 0-degree direction dx, dy, dz, and how many
pieces are oriented from it (read only). A cell is kept as typed; a row that
makes no ToolRosette (a number that is not one, a direction [0, 0, 0]) or a
name another row has is said in one red line under the table and OK is off
until it is put right. Add at the seed (a rosette at the active piece's seed
point, its 0-degree direction the weft there, so the piece's orientation from
it is 0), Delete (refused for a rosette pieces are oriented from). The name of
a rosette pieces use cannot be edited: a new name would leave them naming a
rosette the table lacks. The dialog never changes the document: OK leaves the
new table in :meth:`RosettesDialog.table`, which the caller makes one edit
(``flatweave.document.pieces.set_rosettes``, which re-lays every piece oriented
from a rosette changed); Cancel drops it. Shown window-modal with ``open()``."""

from __future__ import annotations

from dataclasses import dataclass, field

from PySide6.QtCore import QSignalBlocker, Qt
from PySide6.QtGui import QBrush, QColor
from PySide6.QtWidgets import QTableWidgetItem

from flatweave.app.tabledialog import ERROR_COLOUR, RIGHT, TableDialog

from flatweave.document.pieces import free_name, pieces_of
from flatweave.document.rosettes import MAX_ROSETTES, ToolRosette, check_rosettes
from flatweave.errors import FlatweaveError, SettingsError
from flatweave.method.rosette import rosette

__all__ = ["RosettesDialog", "COLUMNS", "KEYS", "NUMBERS"]

# (key, header, tip): the table's columns in order
COLUMNS = (
    ("name", "Name", "The rosette's name: the pieces oriented from it name it"),
    ("ox", "Origin x", "Where the rosette's arrows are drawn (model units); it does not change an orientation"),
    ("oy", "Origin y", "Where the rosette's arrows are drawn (model units); it does not change an orientation"),
    ("oz", "Origin z", "Where the rosette's arrows are drawn (model units); it does not change an orientation"),
    ("dx", "0-deg dx", "The 0-degree direction (any length but zero): a ply's orientation is measured from it, "
                       "projected on the surface at the ply's seed"),
    ("dy", "0-deg dy", "The 0-degree direction (any length but zero)"),
    ("dz", "0-deg dz", "The 0-degree direction (any length but zero)"),
    ("used", "Used by", "How many pieces are oriented from it"),
)
KEYS = tuple(key for key, _, _ in COLUMNS)
NUMBERS = ("ox", "oy", "oz", "dx", "dy", "dz")
LABELS = {"ox": "origin x", "oy": "origin y", "oz": "origin z", "dx": "0-degree dx", "dy": "0-degree dy",
          "dz": "0-degree dz"}
GREY = "#707070"
DUST = 1e-12  # relative: what a surface's evaluation leaves where an exact 0 belongs (a dome's pole: z 1e-16)


def _num(value: float) -> str:
    # + 0.0: a -0.0 reads "0", not "-0"
    return f"{value + 0.0:g}"


def _clean(v) -> tuple[float, float, float]:
    """``v`` as three floats, the evaluation's dust (far below its largest component) made 0."""
    v = [float(x) for x in v]
    big = max(abs(x) for x in v)
    return tuple(0.0 if abs(x) <= DUST * big else x + 0.0 for x in v)


@dataclass
class _Row:
    """A row as edited: ``values`` holds each number column's float, or its text as typed when it
    is not a number (said when the row is checked); ``users`` the pieces oriented from the rosette
    the row was opened with (none for a row added), which fix its name and forbid deleting it."""

    name: str
    values: dict = field(default_factory=dict)
    users: tuple = ()

    @classmethod
    def of(cls, r: ToolRosette, users=()) -> "_Row":
        return cls(r.name, dict(zip(NUMBERS, (*r.origin, *r.zero))), tuple(users))

    def text(self, key: str) -> str:
        if key == "name":
            return self.name
        if key == "used":
            return str(len(self.users))
        v = self.values[key]
        return _num(v) if isinstance(v, float) else v

    def rosette(self) -> ToolRosette:
        """The row's ToolRosette; a one-line SettingsError when it makes none."""
        numbers = []
        for key in NUMBERS:
            v = self.values[key]
            if not isinstance(v, float):
                t = v.strip()
                if not t:
                    raise SettingsError(f"rosette {self.name!r}'s {LABELS[key]} needs a number")
                raise SettingsError(f"rosette {self.name!r}'s {LABELS[key]} must be a number, not {t!r:.30}")
            numbers.append(v)
        return ToolRosette(self.name, tuple(numbers[:3]), tuple(numbers[3:]))


class RosettesDialog(TableDialog):
    """The rosette table of ``project``, edited on a copy; :meth:`table` is the result."""

    def __init__(self, project, parent=None):
        super().__init__("flatweave: rosettes",
                         "The tool's rosettes: the axes the plies are oriented from. Double-click a cell to edit "
                         "it. A ply keeps its orientation from its rosette: its fibres turn with the rosette's "
                         "0-degree direction. The origin only places the arrows in the window.", COLUMNS, parent)
        self.project = project
        self.original = tuple(project.rosettes)
        self._pieces = pieces_of(project)
        self._rows = [_Row.of(r, self.users_of(r.name)) for r in self.original]
        self.add_button = self.tool_button("Add at the seed", "A new rosette at the active piece's seed, its "
                                           "0-degree direction the weft there", self.add_at_seed)
        self.delete_button = self.tool_button("Delete", "Delete the selected rosette (not one pieces are oriented "
                                              "from)", self.delete_selected)
        self._fill()
        if self._rows:
            self.grid.selectRow(0)
        if not self.original:
            self._say("No rosettes yet: Add at the seed makes one where the active piece starts.")
        self.resize(760, 320)

    # ------------------------------------------------------------------ the table
    def users_of(self, name: str) -> list[str]:
        """The pieces oriented from the rosette ``name`` (case and outer spaces aside, as the project
        matches them)."""
        key = name.strip().casefold()
        return [p.name for p in self._pieces if p.rosette is not None and p.rosette.strip().casefold() == key]

    def table(self) -> tuple[ToolRosette, ...]:
        """The table as edited (what OK hands the caller); a one-line SettingsError naming the row
        when a row makes no rosette or two share a name."""
        out = []
        seen: dict[str, int] = {}
        for r, row in enumerate(self._rows):
            try:
                out.append(row.rosette())
            except SettingsError as exc:
                raise SettingsError(f"row {r + 1}: {exc}") from None
            # the project's own check says the name; the rows say where to put it right
            key = row.name.strip().casefold()
            if key in seen:
                raise SettingsError(f"rows {seen[key] + 1} and {r + 1} are both named {row.name!r} "
                                    f"(case and spaces aside)")
            seen[key] = r
        check_rosettes(out, self._pieces)
        return tuple(out)

    def problem(self) -> str:
        """The table's first problem in one line ("" when OK may take it)."""
        try:
            self.table()
        except (FlatweaveError, ValueError, TypeError) as exc:
            return str(exc)
        return ""

    def _show_row(self, r: int) -> None:
        data = self._rows[r]
        try:
            data.rosette()
            bad = False
        except SettingsError:
            bad = True
        for c, key in enumerate(KEYS):
            item = self.cell(r, c)
            item.setText(data.text(key))
            fixed = key == "used" or (key == "name" and data.users)
            flags = item.flags()
            item.setFlags(flags & ~Qt.ItemFlag.ItemIsEditable if fixed else flags | Qt.ItemFlag.ItemIsEditable)
            colour = ERROR_COLOUR if bad else (GREY if key == "used" else None)
            item.setForeground(QBrush(QColor(colour)) if colour else QBrush())
            if key == "name":
                item.setToolTip(f"Pieces are oriented from it ({', '.join(data.users)[:300]}): it keeps its name, "
                                f"which they name" if data.users else "No piece is oriented from it")
            elif key == "used":
                item.setToolTip(f"Oriented from it: {', '.join(data.users)[:300]}" if data.users
                                else "No piece is oriented from it")
                item.setTextAlignment(RIGHT)
            else:
                item.setTextAlignment(RIGHT)

    def _refresh(self) -> None:
        self._check()

    def _check(self) -> bool:
        """OK on only while the table is one the project can take; the first problem said. True when fine."""
        problem = self.problem()
        self.ok_button.setEnabled(not problem)
        if problem:
            self._say(problem[:1].upper() + problem[1:], error=True)
        elif self.status.styleSheet():  # a problem put right: its line goes, a note stays
            self._say("")
        self._update_buttons()
        return not problem

    def _cell_edited(self, item: QTableWidgetItem) -> None:
        r, key = item.row(), KEYS[item.column()]
        if not 0 <= r < len(self._rows):
            return
        data = self._rows[r]
        text = item.text()
        if key == "used":
            pass  # read only: a count, put back below
        elif key == "name":
            name = " ".join(text.split())
            if data.users and name != data.name:
                # the cell is read only; this catches a text set from code (edit_cell)
                self._say(f"{data.name!r} keeps its name: pieces are oriented from it "
                          f"({', '.join(data.users)[:200]})", error=True)
                with QSignalBlocker(self.grid):
                    self._show_row(r)
                self.ok_button.setEnabled(not self.problem())
                return
            data.name = name
        else:
            try:
                data.values[key] = float(text.strip())
            except ValueError:
                data.values[key] = text  # kept as typed so it can be put right; the row is refused meanwhile
        with QSignalBlocker(self.grid):
            self._show_row(r)
        self._check()

    # ------------------------------------------------------------------ rows added and deleted
    def add_at_seed(self) -> bool:
        """A new row at the end: origin the active piece's seed point on the surface, 0-degree
        direction its weft there (so that piece lies at 0 degrees from it), named "rosette N"."""
        if len(self._rows) >= MAX_ROSETTES:
            self._say(f"Not added: a project holds at most {MAX_ROSETTES} rosettes.", error=True)
            return False
        s = self.project.settings
        try:
            here = rosette(self.project.surface, s.seed, s.angle_deg)
            name = free_name((row.name for row in self._rows), "rosette", numbered=True)
            made = ToolRosette(name, _clean(here.origin), _clean(here.weft))
        except (FlatweaveError, ValueError, TypeError, ArithmeticError) as exc:
            self._say(f"Not added: {exc}", error=True)
            return False
        self._rows.append(_Row.of(made))
        self._fill()
        self.grid.selectRow(len(self._rows) - 1)
        if not self.status.styleSheet():
            self._say(f"Added {made.name!r} at {self.project.piece_name!r}'s seed: double-click its cells to "
                      f"change them.")
        return True

    def delete_selected(self) -> bool:
        """Delete the selected row, unless pieces are oriented from its rosette."""
        r = self.selected_row()
        if r is None:
            return False
        data = self._rows[r]
        if data.users:
            self._say(f"{data.name!r} is not deleted: pieces are oriented from it "
                      f"({', '.join(data.users)[:200]}). Orient them from another rosette first.", error=True)
            return False
        del self._rows[r]
        self._fill()
        if self._rows:
            self.grid.selectRow(min(r, len(self._rows) - 1))
        if not self.status.styleSheet():
            self._say(f"Deleted {data.name!r}.")
        return True

    def _update_buttons(self) -> None:
        self.delete_button.setEnabled(self.selected_row() is not None)
        self.add_button.setEnabled(len(self._rows) < MAX_ROSETTES)

    def accept(self) -> None:
        # OK is off while the table is refused, but Return in a cell can still ask
        if self._check():
            super().accept()
