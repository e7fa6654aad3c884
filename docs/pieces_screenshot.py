"""Make docs/images/pieces_panel.png: the Pieces tab on the bundled 24-ply laminate job.

    xvfb-run -s '-screen 0 1600x1000x24' .venv/bin/python docs/pieces_screenshot.py [OUT.png]

Opens resources/jobs/dome-laminate.toml, runs Solve all (the pieces in worker
processes) and grabs the window with ply P02 (+45 degrees from rosette 1)
selected: its weft, warp and the rosette's 0-degree direction at its seed, the
other 23 plies' outlines faint on the tool, its pattern on the right.
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
    win = shot.window(REPO / "resources/jobs/dome-laminate.toml")
    win.side_tabs.setCurrentWidget(win.pieces_panel)
    panel = win.pieces_panel
    finished = []
    win.solve_all.finished.connect(finished.append)
    panel.solve_all.emit()
    shot.wait(lambda: finished)
    panel.list.setCurrentRow(1)
    win.view.reset_camera()
    win.pattern_view.fit()
    shot.settle(1.0)
    shot.save(win.grab(), out)
    print(f"wrote {out}: {finished[0]}")
    win.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
