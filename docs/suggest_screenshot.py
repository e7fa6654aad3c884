"""Make docs/images/suggested_darts.png: Tools > Suggest darts on the woven octant.

    xvfb-run -s '-screen 0 1600x1000x24' .venv/bin/python docs/suggest_screenshot.py [OUT.png]

Solves the woven octant, asks for two suggested darts, waits for them, selects
the second (its curve in orange on the surface, its re-solved piece with both
darts open in the pattern) and grabs the screen with the dialog beside the window.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
os.environ.setdefault("QT_QPA_PLATFORM", "xcb")

from app.nonefix import keep_none_alive

keep_none_alive()  # before any Qt call

from PySide6.QtCore import QEventLoop  # noqa: E402
from PySide6.QtWidgets import QApplication  # noqa: E402

from app.mainwindow import MainWindow  # noqa: E402
from core.examples import example_path, load_example  # noqa: E402
from core.project import new_project  # noqa: E402

REPO = Path(__file__).resolve().parent.parent


def main() -> int:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "docs/images/suggested_darts.png"
    app = QApplication.instance() or QApplication([])
    loop = QEventLoop()

    def wait(cond, timeout=600.0):
        t0 = time.perf_counter()
        while not cond():
            loop.processEvents(QEventLoop.ProcessEventsFlag.AllEvents, 20)
            if time.perf_counter() - t0 > timeout:
                raise TimeoutError("gave up waiting")

    win = MainWindow()
    win.resize(1600, 760)
    win.move(0, 0)
    win.set_project(new_project(load_example("octant"), "octant", str(example_path("octant")), 0.04))
    win.show()
    wait(lambda: win.view.is_ready() and win.pattern_view.is_ready())
    done = []
    win.run_finished.connect(done.append)
    win.run()
    wait(lambda: done)
    win.view.reset_camera()
    box = win.suggest_dialog()
    box.move(0, 770)
    box.resize(900, 220)
    wait(lambda: not box.busy and box.list.count() > 0)
    box.list.setCurrentRow(box.list.count() - 1)
    win.pattern_view.fit()
    t0 = time.perf_counter()
    while time.perf_counter() - t0 < 1.0:
        loop.processEvents(QEventLoop.ProcessEventsFlag.AllEvents, 20)
    shot = app.primaryScreen().grabWindow(0, 0, 0, 1600, 1000)
    shot.save(str(out))
    print(f"wrote {out}")
    box.close()
    win.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
