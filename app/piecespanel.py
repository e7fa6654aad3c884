"""The Pieces tab (issue 41): the project's pieces (:mod:`flatweave.document.pieces`),
the plies of a laminate or the panels of a product, each on its surface. Each row
names a piece with its orientation (or weft angle) and its boundary and area errors (coloured
green when usable, orange with warnings, red when not usable), or says it is
not solved, or stale (its settings changed since); its tip says more.
Selecting a row makes that piece the active one (the views, the settings and
the tools then show and edit it, on its own surface); Add (on the selected piece's
surface, or from a file: the pieces of another face, surface or project), Duplicate at
+45, -45 or 90 degrees or at another angle, Delete, Up and Down edit the list,
a double-click renames. Under the list, the active piece's material, chosen
from the project's materials table, and Materials... to edit that table
(:class:`flatweave.app.materialsdialog.MaterialsDialog`); its rosette, chosen from
the project's rosettes, its orientation from it, and Rosettes... to edit them
(:class:`flatweave.app.rosettesdialog.RosettesDialog`). Below them, once a piece is split by seams,
the Seams list (:class:`flatweave.app.seampanel.SeamList`, ``seams``): each sew line's two
panels and their lengths in the flat, and its seam's options (matched, seam allowance). The
panel never changes the document: a selection is reported as ``piece_selected(index)`` and
every edit as ``piece_edit(label, change, solves)``, ``change`` a function of the project
giving the edited one, which the window makes one document edit (the Seams list's delete and
options, ``seams.seam_delete`` and ``seams.seam_edit``, likewise)."""

from __future__ import annotations

from PySide6.QtCore import QSignalBlocker, Qt, Signal
from PySide6.QtGui import QBrush, QColor, QFont
from PySide6.QtWidgets import (QAbstractItemView, QComboBox, QDoubleSpinBox, QHBoxLayout, QInputDialog, QLabel,
                               QListWidgetItem, QMenu, QToolButton, QVBoxLayout, QWidget)

from flatweave.document import pieces as P
from flatweave.document.checks import project_checks
from flatweave.document.project import Project, settings_equal

from flatweave.app.materialsdialog import MaterialsDialog
from flatweave.app.rosettesdialog import RosettesDialog
from flatweave.app.seampanel import SeamList
from flatweave.app.shortlist import ShortList

__all__ = ["PiecesPanel", "piece_state"]

CHECKS_SHOWN = 4  # the project's warnings listed under the list; more are counted (a laminate's 24 filled the tab)
ANGLES = (45.0, -45.0, 90.0)  # the duplicate menu's turns, degrees added to the piece's orientation (or weft angle)
COLOURS = {"usable": "#1b7a1b", "warnings": "#b86e00", "unusable": "#b00020", "unsolved": "#707070",
           "stale": "#707070"}


def _angle_of(piece) -> float:
    """What a piece's duplicate turns: its orientation from its rosette, or its weft angle."""
    return float(piece.orientation) if piece.rosette is not None else float(piece.settings.angle_deg)


def piece_state(piece) -> str:
    """"unsolved", "stale" (solved with other settings), "unusable", "warnings" or "usable"."""
    r = piece.result
    if r is None:
        return "unsolved"
    if not settings_equal(r.settings, piece.settings):
        return "stale"
    if not r.usable:
        return "unusable"
    return "warnings" if r.warnings else "usable"


def _row_text(piece) -> str:
    """One short line: sequence, name, count, orientation ("+45 deg" from its rosette, "weft +12.5 deg"
    a weft angle alone), and the errors (boundary / area) or the state."""
    state = piece_state(piece)
    if state in ("unsolved", "stale"):
        what = "not solved" if state == "unsolved" else "stale"
    else:
        m = piece.result.metrics
        what = f"{m['boundary_error_pct']:.2f} % / {m['area_error_pct']:.2f} %"
    count = f" x{piece.quantity}" if piece.quantity > 1 else ""
    seq = f"{piece.sequence}. " if piece.sequence is not None else ""
    angle = f"{piece.orientation:+g} deg" if piece.rosette is not None else f"weft {piece.settings.angle_deg:+g} deg"
    return f"{seq}{piece.name}{count}   {angle}   {what}"


def _row_tip(piece) -> str:
    state = piece_state(piece)
    if state == "unsolved":
        return f"{piece.name}: not solved yet"
    if state == "stale":
        return f"{piece.name}: its settings changed since it was solved; run it again"
    m = piece.result.metrics
    return (f"{piece.name}: {piece.result.status}; boundary error {m['boundary_error_pct']:.3f} %, area error "
            f"{m['area_error_pct']:.3f} %, {m['nodes']} nodes" + "".join(f"\n{w}" for w in piece.result.warnings))


class PiecesPanel(QWidget):
    piece_selected = Signal(int)
    piece_edit = Signal(str, object, bool)  # label, change (project -> project), whether a solve answers it
    solve_all = Signal()  # Solve all pressed
    add_from_file = Signal()  # Add > from a file: the window asks for one and adds its pieces

    def __init__(self, parent=None):
        super().__init__(parent)
        self._loading = False
        self._project: Project | None = None
        col = QVBoxLayout(self)
        self.label = QLabel("The pieces of this project: the plies of a laminate, the panels of a product. "
                            "The selected one is shown and edited.")
        self.label.setWordWrap(True)
        col.addWidget(self.label)
        self.list = ShortList(6)
        self.list.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        self.list.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.list.setToolTip("Select a piece to show and edit it; double-click to rename it")
        col.addWidget(self.list, 1)
        line = QHBoxLayout()
        line.addWidget(QLabel("Material"))
        self.material = QComboBox()
        self.material.setToolTip("The active piece's material, a row of the project's materials table: its "
                                 "springs and shear angles become the piece's")
        self.material.setSizeAdjustPolicy(QComboBox.SizeAdjustPolicy.AdjustToMinimumContentsLengthWithIcon)
        self.material.setMinimumContentsLength(12)  # long names are not to widen the side panel
        self.material.activated.connect(self._material_chosen)
        line.addWidget(self.material, 1)
        self.materials_button = QToolButton(text="Materials...")
        self.materials_button.setToolTip("Edit the materials table: presets, springs, shear angles, roll width, "
                                         "thickness, weight; import and export")
        self.materials_button.clicked.connect(self.open_materials)
        line.addWidget(self.materials_button)
        col.addLayout(line)
        self.materials_dialog: MaterialsDialog | None = None
        line = QHBoxLayout()
        line.addWidget(QLabel("Rosette"))
        self.rosette = QComboBox()
        self.rosette.setToolTip("The tool rosette the active piece's orientation is measured from (its 0-degree "
                                "direction projected at the piece's seed), or none: the piece's weft angle alone")
        self.rosette.setSizeAdjustPolicy(QComboBox.SizeAdjustPolicy.AdjustToMinimumContentsLengthWithIcon)
        self.rosette.setMinimumContentsLength(8)
        self.rosette.activated.connect(self._rosette_chosen)
        line.addWidget(self.rosette, 1)
        self.orientation = QDoubleSpinBox()
        self.orientation.setRange(-180.0, 180.0)
        self.orientation.setDecimals(2)
        self.orientation.setSuffix(" deg")
        self.orientation.setWrapping(True)
        self.orientation.setKeyboardTracking(False)  # one edit when the value is entered, not one per key
        self.orientation.setToolTip("The active piece's orientation from its rosette: 0, +45, -45, 90 or any angle")
        self.orientation.valueChanged.connect(self.set_orientation)
        line.addWidget(self.orientation)
        self.rosettes_button = QToolButton(text="Rosettes...")
        self.rosettes_button.setToolTip("Edit the tool's rosettes: origin and 0-degree direction as numbers, or "
                                        "one added at the active piece's seed along its weft")
        self.rosettes_button.clicked.connect(self.open_rosettes)
        line.addWidget(self.rosettes_button)
        col.addLayout(line)
        self.rosettes_dialog: RosettesDialog | None = None
        row = QHBoxLayout()
        self.add = QToolButton(text="Add")
        self.add.setToolTip("A new piece on the surface, with the selected one's material and spacing; the "
                            "arrow adds the pieces of another face, file or project, each on its own surface")
        self.add.setPopupMode(QToolButton.ToolButtonPopupMode.MenuButtonPopup)
        add_menu = QMenu(self.add)
        add_menu.addAction("on this surface", lambda: self.piece_edit.emit("Add piece", P.add, True))
        add_menu.addAction("from a file (a face, a surface, a project)...", self.add_from_file.emit)
        self.add.setMenu(add_menu)
        self.duplicate = QToolButton(text="Duplicate")
        self.duplicate.setToolTip("A copy of the selected piece at another orientation (its weft angle turned)")
        self.duplicate.setPopupMode(QToolButton.ToolButtonPopupMode.InstantPopup)
        menu = QMenu(self.duplicate)
        for a in ANGLES:
            menu.addAction(f"at {a:+g} deg", lambda a=a: self._duplicate(a))
        menu.addAction("at another angle...", self._duplicate_asked)
        menu.addAction("as it is", lambda: self._duplicate(0.0))
        self.duplicate.setMenu(menu)
        self.delete = QToolButton(text="Delete")
        self.up = QToolButton(text="Up")
        self.down = QToolButton(text="Down")
        for w in (self.add, self.duplicate, self.delete, self.up, self.down):
            row.addWidget(w)
        row.addStretch(1)
        col.addLayout(row)
        self.solve_button = QToolButton(text="Solve all")
        self.solve_button.setToolTip("Solve every piece in worker processes, the window staying live; "
                                     "each piece's result comes as it finishes")
        self.solve_button.clicked.connect(self.solve_all.emit)
        self._solving = False
        col.addWidget(self.solve_button)
        self.checks = QLabel()  # the project's consistency warnings (flatweave.document.checks)
        self.checks.setWordWrap(True)
        self.checks.setStyleSheet(f"color: {COLOURS['warnings']}")
        col.addWidget(self.checks)
        self.seams = SeamList()  # shown once a piece is split by seams
        col.addWidget(self.seams)
        self.add.clicked.connect(lambda: self.piece_edit.emit("Add piece", P.add, True))
        self.delete.clicked.connect(self._delete)
        self.up.clicked.connect(lambda: self._move(-1))
        self.down.clicked.connect(lambda: self._move(1))
        self.list.currentRowChanged.connect(self._row_changed)
        self.list.itemDoubleClicked.connect(self._rename_asked)

    # ------------------------------------------------------------------ edits, reported
    def _row(self) -> int | None:
        r = self.list.currentRow()
        return r if r >= 0 and self._project is not None else None

    def _duplicate(self, turn: float) -> None:
        k = self._row()
        if k is None:
            return
        piece = self._project.pieces[k]
        angle = _angle_of(piece) + turn
        if piece.rosette is not None:  # an orientation reads as a ply's: -45 + 90 is +45, not +135 - 180
            angle = (angle + 180.0) % 360.0 - 180.0
        name = None if turn else f"{piece.name} copy"
        self.piece_edit.emit(f"Duplicate {piece.name}", lambda p: P.duplicate(p, k, name, angle), True)

    def _duplicate_asked(self) -> None:
        k = self._row()
        if k is None:
            return
        piece = self._project.pieces[k]
        what = "Orientation" if piece.rosette is not None else "Weft angle"
        angle, ok = QInputDialog.getDouble(self, "Duplicate at an angle", f"{what} of the copy, degrees:",
                                           _angle_of(piece), -360.0, 360.0, 2)
        if ok:
            self.duplicate_at(k, angle)

    def duplicate_at(self, k: int, angle: float) -> None:
        """A copy of piece ``k`` at ``angle``: its orientation from its rosette when it has one, else its
        weft angle (what the menu's "another angle" asks)."""
        self.piece_edit.emit(f"Duplicate {self._project.pieces[k].name}",
                             lambda p: P.duplicate(p, k, None, angle), True)

    def _delete(self) -> None:
        k = self._row()
        if k is not None:
            self.piece_edit.emit(f"Delete {self._project.pieces[k].name}", lambda p: P.remove(p, k), False)

    def _move(self, step: int) -> None:
        k = self._row()
        if k is not None and 0 <= k + step < len(self._project.pieces):
            self.piece_edit.emit("Move piece", lambda p: P.move(p, k, k + step), False)

    def _rename_asked(self, item: QListWidgetItem) -> None:
        k = self.list.row(item)
        old = self._project.pieces[k].name
        name, ok = QInputDialog.getText(self, "Rename piece", "Name:", text=old)
        if ok:
            self.rename(k, name)

    def rename(self, k: int, name: str) -> None:
        """Rename piece ``k`` (what a double-click asks)."""
        name = " ".join(str(name).split())
        if self._project is not None and name != self._project.pieces[k].name:
            self.piece_edit.emit("Rename piece", lambda p: P.rename(p, k, name), False)

    def _material_chosen(self, index: int) -> None:
        name = self.material.itemData(index)
        if name is not None:
            self.choose_material(name)

    def choose_material(self, name: str) -> None:
        """Cut the active piece from the table's material ``name`` (what the material box asks)."""
        if self._project is not None:
            k = self._project.piece_index
            self.piece_edit.emit(f"Material {name}", lambda p: P.use_material(p, k, name), True)

    def open_materials(self) -> MaterialsDialog | None:
        """The materials table in a window-modal dialog; its OK makes the edited table one edit."""
        return self._open_table(MaterialsDialog, "materials_dialog", "Edit materials", P.set_materials)

    def _open_table(self, kind, attribute: str, label: str, setter):
        """A table dialog ``kind`` over the project, kept as ``attribute`` while open; its OK, when the
        table changed, is the edit ``label``: ``setter(project, table)``."""
        if self._project is None:
            return None
        dialog = kind(self._project, self)
        dialog.setAttribute(Qt.WidgetAttribute.WA_DeleteOnClose)

        def accepted():
            table = dialog.table()
            if table != dialog.original:
                self.piece_edit.emit(label, lambda p: setter(p, table), True)

        dialog.accepted.connect(accepted)
        dialog.destroyed.connect(lambda: setattr(self, attribute, None))
        setattr(self, attribute, dialog)
        dialog.open()
        return dialog

    def _rosette_chosen(self, index: int) -> None:
        self.choose_rosette(self.rosette.itemData(index))

    def choose_rosette(self, name: str | None) -> None:
        """Orient the active piece from the rosette ``name``, its fibres kept (None: its weft angle alone)."""
        p = self._project
        if p is not None and name != p.piece_rosette:
            k = p.piece_index
            label = f"Orient {p.piece_name} from {name}" if name else f"{p.piece_name} by its weft angle"
            self.piece_edit.emit(label, lambda q: P.orient(q, k, name), True)

    def set_orientation(self, value: float) -> None:
        """The active piece at ``value`` degrees from its rosette (what the orientation box asks)."""
        p = self._project
        if p is not None and p.piece_rosette is not None and float(value) != p.orientation:
            k, name = p.piece_index, p.piece_rosette
            self.piece_edit.emit(f"Orientation {value:+g}", lambda q: P.orient(q, k, name, float(value)), True)

    def open_rosettes(self) -> RosettesDialog | None:
        """The rosette table in a window-modal dialog; its OK makes the edited table one edit."""
        return self._open_table(RosettesDialog, "rosettes_dialog", "Edit rosettes", P.set_rosettes)

    def _row_changed(self, row: int) -> None:
        if not self._loading and self._project is not None and row >= 0 and row != self._project.piece_index:
            self.piece_selected.emit(row)
        self._update_buttons()

    # ------------------------------------------------------------------ shown
    def set_project(self, project: Project | None) -> None:
        """List ``project``'s pieces (without reporting a selection), the active one selected."""
        self._project = project
        self._loading = True
        try:
            with QSignalBlocker(self.list):
                self.list.clear()
                if project is not None:
                    for k, piece in enumerate(project.pieces):
                        item = QListWidgetItem(_row_text(piece))
                        item.setToolTip(_row_tip(piece))
                        item.setForeground(QBrush(QColor(COLOURS[piece_state(piece)])))
                        if k == project.piece_index:
                            font = QFont(item.font())
                            font.setBold(True)
                            item.setFont(font)
                        self.list.addItem(item)
                    self.list.setCurrentRow(project.piece_index)
        finally:
            self._loading = False
        self._show_material(project)
        self._show_rosette(project)
        warnings = project_checks(project) if project is not None else []
        shown = warnings if len(warnings) <= CHECKS_SHOWN else warnings[:CHECKS_SHOWN - 1] + [
            f"... and {len(warnings) - CHECKS_SHOWN + 1} more (the tip lists them all)"]
        self.checks.setText("\n".join(shown))
        self.checks.setToolTip("\n".join(w[:200] for w in warnings[:200]))
        self.checks.setVisible(bool(warnings))
        self.seams.set_project(project)
        self._update_buttons()

    def _show_material(self, project: Project | None) -> None:
        """The material box: the table's rows, the active piece's selected (a material the table
        lacks shown first, greyed: it cannot be chosen again once left)."""
        with QSignalBlocker(self.material):
            self.material.clear()
            if project is None:
                return
            current = project.settings.material.name
            if project.fabric(current) is None:
                self.material.addItem(f"{current} (not in the table)", None)
                self.material.model().item(0).setEnabled(False)
            for f in project.materials:
                self.material.addItem(f.name, f.name)
                roll = f"{f.roll_width_mm:g} mm roll" if f.roll_width_mm is not None else "not on a roll"
                self.material.setItemData(self.material.count() - 1, f"{f.name}: {f.kind} {f.material.ratio}, shear "
                                          f"{f.material.warn_deg:g} / {f.material.lock_deg:g} deg, {roll}",
                                          Qt.ItemDataRole.ToolTipRole)
            self.material.setCurrentIndex(max(0, self.material.findData(current)))

    def _show_rosette(self, project: Project | None) -> None:
        """The rosette box (none, then the table's rosettes, the active piece's selected) and its
        orientation (enabled when it has a rosette)."""
        with QSignalBlocker(self.rosette), QSignalBlocker(self.orientation):
            self.rosette.clear()
            if project is None:
                return
            self.rosette.addItem("none (weft angle)", None)
            for r in project.rosettes:
                self.rosette.addItem(r.name, r.name)
            self.rosette.setCurrentIndex(max(0, self.rosette.findData(project.piece_rosette)))
            self.orientation.setValue(project.orientation if project.orientation is not None else 0.0)
            self.orientation.setEnabled(project.piece_rosette is not None)

    def materials(self) -> list[str]:
        """The material box's entries as shown."""
        return [self.material.itemText(k) for k in range(self.material.count())]

    def set_solving(self, solving: bool) -> None:
        """While Solve all runs its button says so and waits."""
        self._solving = bool(solving)
        self.solve_button.setText("Solving all..." if solving else "Solve all")
        self._update_buttons()

    def rows(self) -> list[str]:
        return [self.list.item(k).text() for k in range(self.list.count())]

    def _update_buttons(self) -> None:
        p = self._project
        k = self._row()
        n = len(p.pieces) if p is not None else 0
        self.add.setEnabled(p is not None)
        self.material.setEnabled(p is not None)
        self.materials_button.setEnabled(p is not None)
        self.rosette.setEnabled(p is not None and bool(p.rosettes))
        self.rosettes_button.setEnabled(p is not None)
        self.solve_button.setEnabled(p is not None and not self._solving)
        self.duplicate.setEnabled(k is not None)
        self.delete.setEnabled(k is not None and n > 1)
        self.up.setEnabled(k is not None and k > 0)
        self.down.setEnabled(k is not None and k < n - 1)
