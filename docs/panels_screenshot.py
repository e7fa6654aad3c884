"""Make docs/images/panels_window.png: the window with the bundled garment front split into four panels.

    xvfb-run -s '-screen 0 1600x1000x24' .venv/bin/python docs/panels_screenshot.py [OUT_DIR]

Opens the garment front at spacing 0.03, clicks two seams on it with the Seam tool (down its middle,
across its waist), a notch on each with the Notch tool, marks both seams matched and the waist
seam's allowance 12.5 mm (the Seams list's edits, through the document), runs Solve all and grabs
the window: the seams and notches on the surface, the Seams list with each sew line's difference,
its cost and its allowance, the active panel's pattern.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from docs.shotkit import Shot
from flatweave.app.mainwindow import MainWindow
from flatweave.document.project import new_project
from flatweave.reading.examples import example_path, load_example

REPO = Path(__file__).resolve().parent.parent
FRONT = ((0.0, 0.3, 1.4), (0.0, 0.3, 0.0), (0.0, 1.0, 0.0))  # the camera, straight at the front
SEAMS = ([(0.5, 0.003), (0.5, 0.5), (0.5, 0.997)], [(0.003, 0.45), (0.3, 0.48), (0.7, 0.52), (0.997, 0.55)])
NOTCHES = ((0.5, 0.25), (0.5, 0.8), (0.2, 0.47), (0.8, 0.53))


def clicks(win, uv_points) -> None:
    """A press and release of the active tool at each (u, v)'s pixel."""
    for uv in uv_points:
        x, y = win.view.display_point(win.surface.points(np.array([uv], float))[0])
        win.tool.press(x, y, False)
        win.tool.release(x, y)


def main() -> int:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "docs" / "images"
    shot = Shot()
    win = MainWindow()
    win.solve_panels = False  # Solve all, below, solves them once the seams are drawn
    win.resize(1600, 1000)
    win.move(0, 0)
    win.set_project(new_project(load_example("garment"), "garment", str(example_path("garment")), 0.03))
    win.show()
    shot.wait(lambda: win.view.is_ready() and win.pattern_view.is_ready())
    win.view.look(*FRONT)
    win.actions["tool_seam"].trigger()
    for seam in SEAMS:
        clicks(win, seam)
        win.tool.finish()
    win.actions["tool_notch"].trigger()
    clicks(win, NOTCHES)
    win.actions["tool_notch"].trigger()
    doc = win.document
    shape = win.project.sewings[0]
    for s in shape.seams:
        doc.edit_seam(shape.name, s.name, label=f"Match {s.name}", matched=True)
    doc.edit_seam(shape.name, "seam 2", label="Seam allowance of seam 2", allowance_mm=12.5)
    win.side_tabs.setCurrentWidget(win.pieces_panel)
    done = []
    win.solve_all.finished.connect(done.append)
    win.pieces_panel.solve_button.click()
    shot.wait(lambda: done)
    print(done[0])
    win.view.look((0.0, 0.3, 2.6), (0.0, 0.3, 0.0), (0.0, 1.0, 0.0))
    win.pattern_view.fit()
    shot.settle(1.5)
    shot.save(win.grab(), out / "panels_window.png")
    for row in win.pieces_panel.seams.rows():
        print(row)
    win.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
