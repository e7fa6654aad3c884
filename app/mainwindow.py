"""The main window: a 3D view of the surface, File and Examples menus, a status bar."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtGui import QAction, QKeySequence
from PySide6.QtWidgets import (QFileDialog, QLabel, QMainWindow, QMessageBox, QVBoxLayout,
                               QWidget)

from core.errors import FlatweaveError
from core.examples import example_path, list_examples
from core.nurbs import NurbsSurface
from core.surface_io import load_surface

from app.view3d import SurfaceView

GRID_POINTS = 60
SURFACE_FILTER = "Surfaces (*.json);;All files (*)"


def surface_grid(surface: NurbsSurface, n: int = GRID_POINTS):
    """Sample a surface on an n x n grid spanning its parameter domain.

    Returns uv : (n, n, 2), xyz : (n, n, 3), normals : (n, n, 3), with
    uv[i, j] = (u_i, v_j), u and v evenly spaced over the domain, ends included.
    """
    (u0, u1), (v0, v1) = surface.domain
    u, v = np.meshgrid(np.linspace(u0, u1, n), np.linspace(v0, v1, n), indexing="ij")
    uv = np.stack([u, v], axis=-1)
    ev = surface.evaluate(uv.reshape(-1, 2))
    return uv, ev.xyz.reshape(n, n, 3), ev.normal.reshape(n, n, 3)


class MainWindow(QMainWindow):
    """flatweave's main window; one surface document at a time."""

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.surface: NurbsSurface | None = None
        self.surface_path: Path | None = None
        self.last_error: str | None = None  # the last error shown, one line
        self.error_box: QMessageBox | None = None

        self.view = SurfaceView(self)
        central = QWidget(self)
        layout = QVBoxLayout(central)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.view.widget)
        self.setCentralWidget(central)

        self.actions = self._create_actions()
        self._create_menus()
        self._name_label = QLabel(self)
        self._info_label = QLabel(self)
        self.statusBar().addWidget(self._name_label)
        self.statusBar().addPermanentWidget(self._info_label)
        self.resize(1100, 780)
        self._update_actions()
        self._update_title()

    # ------------------------------------------------------------------ actions
    def _create_actions(self) -> dict[str, QAction]:
        acts = {
            "open": QAction("&Open surface...", self, shortcut=QKeySequence.StandardKey.Open,
                            triggered=self.open_dialog),
            "reset_view": QAction("&Reset view", self, shortcut="R",
                                  triggered=self.view.reset_camera),
            "quit": QAction("&Quit", self, shortcut=QKeySequence.StandardKey.Quit,
                            triggered=self.close),
        }
        acts["reset_view"].setShortcutContext(Qt.ShortcutContext.WindowShortcut)
        return acts

    def _create_menus(self) -> None:
        bar = self.menuBar()
        file_menu = bar.addMenu("&File")
        file_menu.addAction(self.actions["open"])
        file_menu.addSeparator()
        file_menu.addAction(self.actions["quit"])
        self.examples_menu = bar.addMenu("&Examples")
        try:
            examples = list_examples()
        except (FlatweaveError, OSError, ValueError):  # a broken install: no menu entries
            examples = []
        for entry in examples:
            name = entry["name"]
            act = QAction(entry.get("title") or name, self)
            act.setData(name)
            if entry.get("description"):
                act.setStatusTip(entry["description"])
            act.triggered.connect(lambda checked=False, n=name: self.open_example(n))
            self.examples_menu.addAction(act)
        if not examples:
            self.examples_menu.addAction("(no examples found)").setEnabled(False)
        view_menu = bar.addMenu("&View")
        view_menu.addAction(self.actions["reset_view"])

    def _update_actions(self) -> None:
        """Enable or disable actions for the current document (the one place that does)."""
        self.actions["reset_view"].setEnabled(self.surface is not None)

    def _update_title(self) -> None:
        name = self.surface_name
        self.setWindowTitle(f"flatweave - {name}" if name else "flatweave")

    # ------------------------------------------------------------------ document
    @property
    def surface_name(self) -> str | None:
        return None if self.surface_path is None else self.surface_path.stem

    def set_surface(self, surface: NurbsSurface, path: str | Path | None = None) -> None:
        """Show ``surface`` (loaded from ``path``, if given)."""
        _, xyz, normals = surface_grid(surface)
        self.surface = surface
        self.surface_path = None if path is None else Path(path)
        self.view.set_surface(xyz, normals)
        self._name_label.setText(self.surface_name or "(unnamed surface)")
        p, q = surface.degree_u, surface.degree_v
        nu, nv = surface.shape
        kind = "rational" if surface.rational else "polynomial"
        self._info_label.setText(f"{kind}, degree {p}x{q}, {nu}x{nv} control points")
        self._update_actions()
        self._update_title()

    def open_file(self, path: str | Path) -> bool:
        """Load a surface file and show it; on failure show the error and keep the old one."""
        try:
            surface = load_surface(path)
        except (FlatweaveError, OSError) as exc:
            self.show_error(f"Cannot open surface: {exc}")
            return False
        self.set_surface(surface, path)
        self.statusBar().showMessage(f"Opened {path}", 5000)
        return True

    def open_example(self, name: str) -> bool:
        return self.open_file(example_path(name))

    def open_dialog(self) -> None:
        start = str(self.surface_path.parent) if self.surface_path else ""
        path, _ = QFileDialog.getOpenFileName(self, "Open surface", start, SURFACE_FILTER)
        if path:
            self.open_file(path)

    def show_error(self, message: str) -> None:
        """Show a one-line error without blocking (a window-modal box, opened, not exec'd)."""
        self.last_error = message
        self.statusBar().showMessage(message, 10000)
        if self.error_box is not None:
            self.error_box.close()
        box = QMessageBox(QMessageBox.Icon.Warning, "flatweave", message,
                          QMessageBox.StandardButton.Ok, self)
        box.setAttribute(Qt.WidgetAttribute.WA_DeleteOnClose)
        box.finished.connect(self._error_box_finished)
        self.error_box = box
        box.open()

    def _error_box_finished(self, _result: int) -> None:
        self.error_box = None

    # ------------------------------------------------------------------ lifetime
    def closeEvent(self, event) -> None:  # noqa: N802 (Qt name)
        # The render window must go before the widgets holding it are destroyed.
        self.view.close()
        super().closeEvent(event)
