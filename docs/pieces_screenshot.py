"""Make docs/images/pieces_panel.png: the Pieces tab on three plies of the woven octant.

    xvfb-run -s '-screen 0 1600x1000x24' .venv/bin/python docs/pieces_screenshot.py [OUT.png]

Solves the woven octant, duplicates it at +45 and at 90 degrees from the Pieces
tab, solves the +45 ply (the 90 one is left unsolved, to show its state), and
grabs the window with the +45 ply selected.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from docs.shotkit import Shot

REPO = Path(__file__).resolve().parent.parent


def main() -> int:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "docs/images/pieces_panel.png"
    shot = Shot()
    win = shot.solved_window("octant", 0.04)
    win.side_tabs.setCurrentWidget(win.pieces_panel)
    panel = win.pieces_panel
    panel.rename(0, "ply 1 (0)")
    panel.duplicate_at(0, 45.0)
    panel.rename(1, "ply 2 (+45)")
    done = []
    win.run_finished.connect(done.append)
    win.run()
    shot.wait(lambda: done)
    panel.duplicate_at(1, 90.0)
    panel.rename(2, "ply 3 (90)")
    panel.list.setCurrentRow(1)
    win.view.reset_camera()
    win.pattern_view.fit()
    shot.settle(1.0)
    win.grab().save(str(out))
    print(f"wrote {out}: {panel.rows()}")
    win.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
