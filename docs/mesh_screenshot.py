"""Make docs/images/mesh_deviation.png: a mesh opened in the window, its fit's deviation.

    xvfb-run -s '-screen 0 1600x1000x24' .venv/bin/python docs/mesh_screenshot.py [OUT.png]

Writes a binary STL of a garment-like panel (a bulging front over a curved
body, the shape of tests/test_meshsurf.py), opens it with File > Open's code
path, solves it, turns on View > Mesh fit deviation and View > Mesh beside the
surface (the mesh, coloured by each vertex's distance to the fitted surface,
beside the surface and its cloth) and grabs the window.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
os.environ.setdefault("QT_QPA_PLATFORM", "xcb")

from flatweave.app.nonefix import keep_none_alive

keep_none_alive()  # before any Qt call

import trimesh  # noqa: E402
from PySide6.QtCore import QEventLoop  # noqa: E402
from PySide6.QtWidgets import QApplication  # noqa: E402

from flatweave.app.mainwindow import MainWindow  # noqa: E402

REPO = Path(__file__).resolve().parent.parent


def panel_mesh(nu: int = 50, nv: int = 70):
    u, v = np.meshgrid(np.linspace(0, 1, nu), np.linspace(0, 1, nv), indexing="ij")
    u, v = u.ravel(), v.ravel()
    idx = np.arange(nu * nv).reshape(nu, nv)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    F = np.r_[np.stack([a, b, c], 1), np.stack([a, c, d], 1)]
    x, y = 0.5 * u, 0.7 * v
    V = np.stack([x, y, 0.25 * np.sin(np.pi * u) * (0.6 + 0.4 * np.sin(np.pi * v)) + 0.08 * u * v], 1)
    return V, F


def main() -> int:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "docs/images/mesh_deviation.png"
    app = QApplication.instance() or QApplication([])  # noqa: F841 (kept alive while the window runs)
    loop = QEventLoop()

    def wait(cond, timeout=600.0):
        t0 = time.perf_counter()
        while not cond():
            loop.processEvents(QEventLoop.ProcessEventsFlag.AllEvents, 20)
            if time.perf_counter() - t0 > timeout:
                raise TimeoutError("gave up waiting")

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "panel.stl"
        path.write_bytes(trimesh.Trimesh(*panel_mesh(), process=False).export(file_type="stl"))
        win = MainWindow()
        win.resize(1600, 1000)
        win.move(0, 0)
        win.show()
        wait(lambda: win.view.is_ready() and win.pattern_view.is_ready())
        if not win.open_file(path):
            return 1
        done = []
        win.run_finished.connect(done.append)
        win.run()
        wait(lambda: done)
        win.actions["show_fit_deviation"].trigger()
        win.actions["show_fit_mesh"].trigger()
        win.pattern_view.fit()
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < 1.0:
            loop.processEvents(QEventLoop.ProcessEventsFlag.AllEvents, 20)
        shot = win.grab()
        shot.save(str(out))
        print(f"wrote {out}: {win.metrics.text('fit')}")
        win.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
