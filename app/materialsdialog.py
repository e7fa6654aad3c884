"""The materials table, edited (issue 41): a dialog over a copy of a project's
table (:attr:`flatweave.document.project.Project.materials`, rows
:class:`flatweave.method.materials.Fabric`). One row per material: its name,
its kind (woven, isotropic or custom, read from the spring ratio, not edited),
the spring constants weft:warp:diagonal, the shear warning and lock angles,
roll width, thickness and areal weight (an empty cell: not known). A cell
edited is checked by making the row's ``Fabric``; a value refused is said
under the table and the cell goes back. Add preset (the bundled
:data:`~flatweave.method.materials.FABRICS` the table lacks), Add copy, Delete
(refused for a material a piece is cut from), Import (rows read from a
materials file replace the rows of the same name, the others are added) and
Export (the table as it stands, to a file of its own). The dialog never
changes the document: OK leaves the new table in :meth:`MaterialsDialog.table`,
which the caller makes one edit (``Document.set_materials``); Cancel drops it."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from PySide6.QtCore import QSignalBlocker, Qt
from PySide6.QtGui import QBrush, QColor
from PySide6.QtWidgets import QFileDialog, QMenu, QTableWidgetItem, QToolButton

from flatweave.app.tabledialog import RIGHT, TableDialog

from flatweave.document.pieces import free_name, pieces_of
from flatweave.errors import FlatweaveError, SettingsError
from flatweave.method.materials import FABRICS, Fabric, check_table, load_materials, save_materials

__all__ = ["MaterialsDialog", "COLUMNS", "cell_text", "edited_fabric"]

# (key, header, tip): the table's columns in order
COLUMNS = (
    ("name", "Name", "The material's name: the pieces cut from it name it"),
    ("kind", "Kind", "Woven, isotropic or custom: read from the spring ratio"),
    ("ratio", "Springs\nweft:warp:diag", "The spring constants of the weft, warp and diagonal springs"),
    ("warn", "Shear warning\n(deg)", "Beyond this shear angle the cloth shears visibly"),
    ("lock", "Lock\n(deg)", "Beyond this shear angle the cloth wrinkles instead (at most 90)"),
    ("roll", "Roll width\n(mm)", "The width of the roll it is sold on; empty when not sold on a roll"),
    ("thickness", "Thickness\n(mm)", "Empty when not known"),
    ("weight", "Weight\n(g/m²)", "Areal weight; empty when not known"),
)
KEYS = tuple(key for key, _, _ in COLUMNS)
FILTER = "Materials tables (*.json);;All files (*)"


def _num(value) -> str:
    return "" if value is None else f"{value:g}"


def cell_text(fabric: Fabric, key: str) -> str:
    """What column ``key`` shows of ``fabric`` (empty: none)."""
    m = fabric.material
    return {"name": m.name, "kind": fabric.kind, "ratio": m.ratio, "warn": _num(m.warn_deg),
            "lock": _num(m.lock_deg), "roll": _num(fabric.roll_width_mm), "thickness": _num(fabric.thickness_mm),
            "weight": _num(fabric.areal_weight_gsm)}[key]


def _number(text: str, label: str, optional: bool) -> float | None:
    t = text.strip()
    if not t or t.lower() == "none":
        if optional:
            return None
        raise SettingsError(f"the {label} needs a number")
    try:
        return float(t)
    except ValueError:
        raise SettingsError(f"the {label} must be a number, not {t!r:.30}") from None


def edited_fabric(fabric: Fabric, key: str, text: str) -> Fabric:
    """``fabric`` with column ``key`` set from ``text``; a one-line SettingsError when the value
    (or the row it makes) is refused."""
    m = fabric.material
    if key == "name":
        return replace(fabric, material=replace(m, name=" ".join(text.split())))
    if key == "ratio":
        parts = text.replace(" ", "").split(":")
        try:
            k = [float(p) for p in parts]
        except ValueError:
            k = []
        if len(k) != 3:
            raise SettingsError(f"the springs are three numbers weft:warp:diagonal (500:500:1 a woven), "
                                f"not {text.strip()!r:.30}")
        return replace(fabric, material=replace(m, k_weft=k[0], k_warp=k[1], k_diag=k[2]))
    if key in ("warn", "lock"):
        label = "shear warning angle" if key == "warn" else "lock angle"
        field = "warn_deg" if key == "warn" else "lock_deg"
        return replace(fabric, material=replace(m, **{field: _number(text, label, False)}))
    field, label = {"roll": ("roll_width_mm", "roll width"), "thickness": ("thickness_mm", "thickness"),
                    "weight": ("areal_weight_gsm", "areal weight")}[key]
    return replace(fabric, **{field: _number(text, label, True)})


class MaterialsDialog(TableDialog):
    """The materials table of ``project``, edited on a copy; :meth:`table` is the result."""

    def __init__(self, project, parent=None):
        super().__init__("flatweave: materials",
                         "The materials this project's pieces are cut from. Double-click a cell to edit it; "
                         "an empty cell is not known. A row's values go to every piece cut from it.", COLUMNS, parent)
        self.original = tuple(project.materials)
        self._rows = list(self.original)
        self.used: dict[str, list[str]] = {}  # material name -> the pieces cut from it
        for p in pieces_of(project):
            self.used.setdefault(p.settings.material.name, []).append(p.name)
        self.add_preset_button = self.tool_button("Add preset", "A bundled material the table lacks (typical "
                                                  "catalogue values)")
        self.add_preset_button.setPopupMode(QToolButton.ToolButtonPopupMode.InstantPopup)
        self.add_preset_button.setMenu(QMenu(self.add_preset_button))
        self.add_copy_button = self.tool_button("Add copy", "A copy of the selected material, under a new name",
                                                self.add_copy)
        self.delete_button = self.tool_button("Delete", "Delete the selected material (not one a piece is cut "
                                              "from)", self.delete_selected)
        self.import_button = self.tool_button("Import...", "Read a materials file: its rows replace the rows of "
                                              "the same name, the others are added", self.import_asked)
        self.export_button = self.tool_button("Export...", "Write this table to a materials file, to read into "
                                              "other projects", self.export_asked)
        self._fill()
        if self._rows:
            self.grid.selectRow(0)
        head = self.grid.horizontalHeader()
        width = max((self.grid.fontMetrics().horizontalAdvance(f.name) for f in self._rows), default=120) + 24
        width += sum(max(head.sectionSizeFromContents(c).width(), self.grid.sizeHintForColumn(c))
                     for c in range(1, len(COLUMNS)))
        self.resize(max(760, width + 60), 380)

    # ------------------------------------------------------------------ the table
    def table(self) -> tuple[Fabric, ...]:
        """The table as edited (what OK hands the caller)."""
        return tuple(self._rows)

    def _show_row(self, r: int) -> None:
        fabric = self._rows[r]
        users = self.used.get(fabric.name, [])
        tip = f"Cut from it: {', '.join(users)[:300]}" if users else "No piece is cut from it"
        for c, key in enumerate(KEYS):
            item = self.cell(r, c)
            item.setText(cell_text(fabric, key))
            if key == "kind":
                item.setFlags(item.flags() & ~Qt.ItemFlag.ItemIsEditable)
                item.setForeground(QBrush(QColor("#707070")))
                item.setToolTip("Read from the spring ratio: diagonals far softer than the threads are a woven, "
                                "half the threads' an isotropic sheet")
            elif key == "name":
                item.setToolTip(tip)
            else:
                item.setTextAlignment(RIGHT)

    def _cell_edited(self, item: QTableWidgetItem) -> None:
        r, key = item.row(), KEYS[item.column()]
        if not 0 <= r < len(self._rows) or key == "kind":
            return
        old = self._rows[r]
        try:
            new = edited_fabric(old, key, item.text())
            if new.name != old.name:
                if old.name in self.used:
                    raise SettingsError(f"{old.name!r} keeps its name: pieces are cut from it "
                                        f"({', '.join(self.used[old.name])[:200]})")
                check_table(self._rows[:r] + [new] + self._rows[r + 1:], "the materials table")
        except (FlatweaveError, ValueError, TypeError) as exc:
            self._say(f"Not changed: {exc}", error=True)
            with QSignalBlocker(self.grid):
                self._show_row(r)
            return
        self._rows[r] = new
        with QSignalBlocker(self.grid):
            self._show_row(r)
        self._say("")
        self._update_buttons()

    # ------------------------------------------------------------------ rows added and deleted
    def _insert(self, fabric: Fabric, at: int | None = None) -> None:
        at = len(self._rows) if at is None else at
        self._rows.insert(at, fabric)
        self._fill()
        self.grid.selectRow(at)

    def missing_presets(self) -> list[str]:
        """The bundled presets the table lacks (by name)."""
        have = {f.name.strip().casefold() for f in self._rows}
        return [name for name in FABRICS if name.strip().casefold() not in have]

    def add_preset(self, name: str) -> None:
        """Add the bundled material ``name`` at the end."""
        if name in self.missing_presets():
            self._insert(FABRICS[name])
            self._say(f"Added {name!r}.")

    def add_copy(self) -> None:
        """A copy of the selected row after it, named after it."""
        r = self.selected_row()
        if r is None:
            return
        src = self._rows[r]
        name = free_name([f.name for f in self._rows], f"{src.name} copy")
        self._insert(replace(src, material=replace(src.material, name=name)), r + 1)
        self._say(f"Added {name!r}: double-click its cells to change them.")

    def delete_selected(self) -> None:
        r = self.selected_row()
        if r is None:
            return
        name = self._rows[r].name
        if name in self.used:
            self._say(f"{name!r} is not deleted: pieces are cut from it ({', '.join(self.used[name])[:200]}). "
                      f"Choose another material for them first.", error=True)
            return
        if len(self._rows) == 1:
            self._say("The table keeps at least one material.", error=True)
            return
        del self._rows[r]
        self._fill()
        self.grid.selectRow(min(r, len(self._rows) - 1))
        self._say(f"Deleted {name!r}.")

    def _update_buttons(self) -> None:
        menu = self.add_preset_button.menu()
        menu.clear()
        missing = self.missing_presets()
        for name in missing:
            menu.addAction(f"{name} ({FABRICS[name].kind})", lambda name=name: self.add_preset(name))
        self.add_preset_button.setEnabled(bool(missing))
        r = self.selected_row()
        self.add_copy_button.setEnabled(r is not None)
        self.delete_button.setEnabled(r is not None and len(self._rows) > 1)

    # ------------------------------------------------------------------ files
    def _ask_path(self, save: bool) -> str:
        """A materials file to write (``save``) or read; "" when cancelled. Tests replace it."""
        if save:
            path, _ = QFileDialog.getSaveFileName(self, "Export materials", "materials.json", FILTER)
        else:
            path, _ = QFileDialog.getOpenFileName(self, "Import materials", "", FILTER)
        return path

    def import_asked(self) -> None:
        path = self._ask_path(False)
        if path:
            self.import_from(path)

    def import_from(self, path) -> bool:
        """Merge the table in ``path``: a row replaces the row of the same name (case and outer spaces aside,
        keeping the table's spelling, which the pieces name), the others are added at the end."""
        try:
            rows = load_materials(path)
        except (FlatweaveError, OSError) as exc:
            self._say(f"Not imported: {exc}", error=True)
            return False
        index = {f.name.strip().casefold(): k for k, f in enumerate(self._rows)}
        replaced = added = 0
        for f in rows:
            k = index.get(f.name.strip().casefold())
            if k is None:
                index[f.name.strip().casefold()] = len(self._rows)
                self._rows.append(f)
                added += 1
            else:
                old = self._rows[k].name
                self._rows[k] = f if f.name == old else replace(f, material=replace(f.material, name=old))
                replaced += 1
        self._fill()
        self._say(f"Read {len(rows)} materials from {Path(path).name}: {replaced} replaced, {added} added.")
        return True

    def export_asked(self) -> None:
        path = self._ask_path(True)
        if path:
            self.export_to(path if Path(path).suffix else f"{path}.json")

    def export_to(self, path) -> bool:
        """Write the table as it stands to ``path``."""
        try:
            save_materials(self.table(), path)
        except (FlatweaveError, OSError) as exc:
            self._say(f"Not exported: {exc}", error=True)
            return False
        self._say(f"Wrote {len(self._rows)} materials to {path}.")
        return True
