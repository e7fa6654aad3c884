"""How long a click takes to place a point of a panel's outline on a raw scan
in the window's panel picker (issue 40: under 50 ms at 200,000 triangles).

Measured by ``benchmarks/suite.py`` (case ``scan_click``, in a child process
under an X display). The scan is face000 at ``triangles`` triangles
(:func:`benchmarks.scan_fit.large_scan`: its triangles split in four, the
ones nearest the centre kept). The picker opens on it (File > Open's
dialog for a mesh far from developable, or of several parts); twelve
clicks round the face with real mouse events on its view; each is timed
from the press to the point drawn (the pick through VTK's cell picker and
the loop redrawn). ``click_ms`` is their median, ``max_ms`` the slowest.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
os.environ.setdefault("QT_QPA_PLATFORM", "xcb")

CLICKS = 12


def measure(triangles: int) -> dict:
    from flatweave.app.nonefix import keep_none_alive

    keep_none_alive()
    from PySide6.QtCore import Qt
    from PySide6.QtTest import QTest
    from PySide6.QtWidgets import QApplication

    from benchmarks.dart_tool import qt_point, wait
    from benchmarks.scan_fit import large_scan
    from flatweave.app.meshpicker import MeshLoopPicker
    from flatweave.reading.registry import open_path
    from tests.helpers import data_cache

    app = QApplication.instance() or QApplication([])
    folder = Path(data_cache()) / "derived"
    folder.mkdir(parents=True, exist_ok=True)
    opened = open_path(large_scan(triangles, folder))
    picker = MeshLoopPicker(opened)
    picker.resize(1000, 800)
    picker.show()
    wait(app, lambda: picker.view.widget.isVisible())
    picker.view.render_now()
    widget = picker.view.widget
    w, h = widget.width(), widget.height()
    t = np.linspace(0, 2 * np.pi, CLICKS, endpoint=False)
    times = []
    for x, y in zip(w / 2 + 0.2 * w * np.cos(t), h / 2 + 0.2 * h * np.sin(t)):
        n = len(picker.points)
        t0 = time.perf_counter()
        QTest.mouseClick(widget, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier,
                         qt_point(widget, (x, y)))
        times.append(time.perf_counter() - t0)
        if len(picker.points) != n + 1:
            raise RuntimeError("a click round the face placed no point")
    picker.close()
    return {"click_ms": 1e3 * float(np.median(times)), "max_ms": 1e3 * float(np.max(times)),
            "triangles": float(len(opened.mesh.triangles))}
