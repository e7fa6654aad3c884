"""Make docs/images/cut_plan.png: the window's Cut plan under the views.

    xvfb-run -s '-screen 0 1600x1000x24' .venv/bin/python docs/cutplan_screenshot.py [OUT_DIR]

A project of two woven plies of the octant (2 copies each, the second turned +45 degrees) and an
isotropic half-cylinder panel, solved; Solve > Nest pieces on the roll with a 1 m roll (every piece
spliced in two), "cap" cut in mirror pairs, and a 2 s time limit; the woven marker shown, the ply
"cap" selected, its splice on the surface and in the Cut plan's splice view.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from docs.shotkit import Shot
from flatweave.app.mainwindow import MainWindow
from flatweave.document import pieces as P
from flatweave.document.project import new_project
from flatweave.document.solving import solve_pieces
from flatweave.method.lattice import MATERIALS
from flatweave.method.settings import FlattenSettings
from flatweave.reading.examples import load_example

REPO = Path(__file__).resolve().parent.parent


def kit():
    p = new_project(load_example("octant"), "kit", "octant", spacing=0.1)
    p = P.rename(p, 0, "cap")
    p = P.set_quantity(p, 0, 2)
    p = P.duplicate(p, 0, "cap +45", angle_deg=45.0)
    p = P.add(p, "side", FlattenSettings(spacing=0.1, material=MATERIALS["isotropic"]),
              surface=load_example("half_cylinder"), source="half_cylinder")
    return solve_pieces(p, workers=1)[0]


def main() -> int:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "docs" / "images"
    shot = Shot()
    win = MainWindow()
    win.resize(1600, 1000)
    win.move(0, 0)
    win.set_project(kit())
    win.show()
    shot.wait(lambda: win.view.is_ready() and win.pattern_view.is_ready())
    done = []
    win.cut_plan.finished.connect(done.append)
    win.cut_plan.failed.connect(done.append)
    win.cut_plan.time_limit.setValue(2)
    win.cut_plan.set_roll_width(1000.0)  # every octant ply wider: spliced in two
    win.cut_plan.set_mirror("cap", True)  # its two copies a left and a right
    win.actions["nest"].trigger()
    shot.wait(lambda: done, 120)
    print(done[0])
    win.cut_plan.choose_material("woven")
    win.document.select_piece("cap")  # a woven ply shown, its splice drawn on it
    shot.wait(lambda: win.view.is_ready())
    shot.settle(1.0)
    shot.save(win.grab(), out / "cut_plan.png")
    win.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
