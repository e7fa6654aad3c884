"""The darts panel's list of candidate regions (:mod:`flatweave.document.candidates`):
the active region first, then the regions kept beside it (tick to show one on
the surface, double-click to rename); Keep copy, Use (make the selected one
active) and Delete. Shown once there is a region. It never changes the document: each button or edit is
reported as ``region_edit(label, change, solves)``, ``change`` a function of
the project giving the edited one, which the window makes one document edit."""

from __future__ import annotations

from PySide6.QtCore import QSignalBlocker, Qt, Signal
from PySide6.QtGui import QFont
from PySide6.QtWidgets import QAbstractItemView, QGroupBox, QHBoxLayout, QListWidgetItem, QToolButton, QVBoxLayout

from flatweave.document import candidates as cand
from flatweave.document.project import Project

from flatweave.app.shortlist import ShortList

__all__ = ["RegionList"]


class RegionList(QGroupBox):
    region_edit = Signal(str, object, bool)  # label, change (project -> project), whether it re-solves

    def __init__(self, parent=None):
        super().__init__("Regions", parent)
        self._loading = False
        self._project: Project | None = None
        col = QVBoxLayout(self)
        self.list = ShortList(2)
        self.list.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        self.list.setEditTriggers(QAbstractItemView.EditTrigger.DoubleClicked
                                  | QAbstractItemView.EditTrigger.EditKeyPressed)
        self.list.setToolTip("The active region (bold) and the regions kept beside it: tick to show one on the "
                             "surface, double-click to rename")
        col.addWidget(self.list)
        row = QHBoxLayout()
        self.keep = QToolButton(text="Keep copy")
        self.keep.setToolTip("Keep a copy of the active region, to draw another in its place")
        self.use = QToolButton(text="Use")
        self.use.setToolTip("Make the selected kept region the active one (the piece re-solves)")
        self.delete = QToolButton(text="Delete")
        self.delete.setToolTip("Delete the selected kept region")
        for w in (self.keep, self.use, self.delete):
            row.addWidget(w)
        row.addStretch(1)
        col.addLayout(row)
        self.keep.clicked.connect(lambda: self.region_edit.emit("Keep region", cand.keep_copy, False))
        self.use.clicked.connect(self._use)
        self.delete.clicked.connect(self._delete)
        self.list.itemChanged.connect(self._item_changed)
        self.list.currentRowChanged.connect(lambda _r: self._update_buttons())

    def _kept_row(self) -> int | None:
        r = self.list.currentRow()
        return r - 1 if r >= 1 else None

    def _use(self) -> None:
        k = self._kept_row()
        if k is not None:
            name = self._project.candidates[k].name
            self.region_edit.emit(f"Use {name}", lambda p: cand.activate(p, k), True)

    def _delete(self) -> None:
        k = self._kept_row()
        if k is not None:
            name = self._project.candidates[k].name
            self.region_edit.emit(f"Delete {name}", lambda p: cand.remove(p, k), False)

    def _item_changed(self, item: QListWidgetItem) -> None:
        if self._loading or self._project is None:
            return
        r = self.list.row(item)
        k = None if r == 0 else r - 1
        old = cand.active_name(self._project) if k is None else self._project.candidates[k].name
        name = item.text().strip()
        if name != old:
            self.region_edit.emit("Rename region", lambda p: cand.rename(p, k, name), False)
        elif k is not None and (item.checkState() == Qt.CheckState.Checked) != self._project.candidates[k].visible:
            on = item.checkState() == Qt.CheckState.Checked
            self.region_edit.emit(f"{'Show' if on else 'Hide'} {old}", lambda p: cand.set_visible(p, k, on), False)

    def set_project(self, project: Project | None) -> None:
        """List ``project``'s regions (without reporting edits), keeping the selected row;
        hidden while there is no region to keep (the whole surface, nothing kept), so the
        darts panel keeps its room."""
        self._project = project
        self.setVisible(project is not None and (project.settings.region is not None or bool(project.candidates)))
        row = self.list.currentRow()
        self._loading = True
        try:
            with QSignalBlocker(self.list):
                self.list.clear()
                if project is not None:
                    active = QListWidgetItem(cand.active_name(project) + (
                        "" if project.settings.region is not None else " (the whole surface)"))
                    font = QFont(active.font())
                    font.setBold(True)
                    active.setFont(font)
                    active.setFlags(active.flags() | Qt.ItemFlag.ItemIsEditable)
                    active.setToolTip("The active region: the piece being solved")
                    self.list.addItem(active)
                    for c in project.candidates:
                        item = QListWidgetItem(c.name)
                        item.setFlags(item.flags() | Qt.ItemFlag.ItemIsEditable | Qt.ItemFlag.ItemIsUserCheckable)
                        item.setCheckState(Qt.CheckState.Checked if c.visible else Qt.CheckState.Unchecked)
                        self.list.addItem(item)
                    if 0 <= row < self.list.count():
                        self.list.setCurrentRow(row)
        finally:
            self._loading = False
        self._update_buttons()

    def names(self) -> list[str]:
        return [self.list.item(k).text() for k in range(self.list.count())]

    def _update_buttons(self) -> None:
        p = self._project
        self.keep.setEnabled(p is not None)
        kept = self._kept_row() is not None
        self.use.setEnabled(kept)
        self.delete.setEnabled(kept)
