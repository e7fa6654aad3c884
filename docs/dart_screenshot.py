"""Make docs/images/dart_tool.png: the app drawing a curve dart on the octant.

    xvfb-run -s '-screen 0 1600x1000x24' .venv/bin/python docs/dart_screenshot.py [OUT.png]

Solves the woven octant, draws a first curve dart from the rim with the tool
(real clicks on the 3D view, then Enter) and waits for its re-solve, so the
pattern shows it open into a V; then clicks the first points of a second dart
and grabs the window while that one is being drawn.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from docs.shotkit import Shot

from PySide6.QtCore import QPoint, Qt
from PySide6.QtTest import QTest

REPO = Path(__file__).resolve().parent.parent


def sphere(lon_deg: float, lat_deg: float) -> np.ndarray:
    lon, lat = np.radians(lon_deg), np.radians(lat_deg)
    return np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])


def main() -> int:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "docs/images/dart_tool.png"
    shot = Shot()
    wait, loop = shot.wait, shot.loop
    win = shot.solved_window("octant", 0.04)
    done = []
    win.run_finished.connect(done.append)
    view = win.view
    view.reset_camera()  # the home view: the whole piece
    view.render_now()
    win.activateWindow()
    wait(win.isActiveWindow, 10)
    widget = view.widget

    def click_at(x, y):
        QTest.mouseClick(widget, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier,
                         QPoint(int(round(x)), widget.height() - 1 - int(round(y))))
        loop.processEvents()

    def click(xyz):
        click_at(*view.display_point(xyz))

    def click_off_rim(rim, outside):
        """Click 5 pixels beyond the rim point ``rim``, towards ``outside``: the tool snaps it onto the rim."""
        a, b = np.array(view.display_point(rim)), np.array(view.display_point(outside))
        click_at(*(a + 5 * (b - a) / np.linalg.norm(b - a)))

    win.actions["tool_curve_dart"].setChecked(True)
    # the first dart: from the equator (a click just below it, snapped onto the rim) towards the pole
    click_off_rim(sphere(45, 0), sphere(45, -10))
    for p in (sphere(43, 22), sphere(47, 44)):
        click(p)
    done.clear()
    QTest.keyClick(widget, Qt.Key.Key_Return)
    wait(lambda: done)
    # the second, being drawn: from the x-z edge inwards
    click_off_rim(sphere(0, 52), sphere(-10, 52))
    for p in (sphere(12, 49), sphere(22, 52), sphere(31, 57)):
        click(p)
    win.pattern_view.fit()
    view.render_now()
    win.pattern_view.render_now()
    loop.processEvents()
    time.sleep(0.3)
    loop.processEvents()
    shot.save(win.grab(), out)
    print(f"wrote {out}; status: {win.statusBar().currentMessage()}")
    win.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
