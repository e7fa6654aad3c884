"""Make docs/images/materials_dialog.png: the materials table editor over two plies of the octant.

    xvfb-run -s '-screen 0 1600x1000x24' .venv/bin/python docs/materials_screenshot.py [OUT.png]

Opens the woven octant, cuts its piece from the carbon preset and duplicates it
at +45 degrees from the Pieces tab, opens Materials..., adds a copy of the
carbon row for another supplier (its roll width and weight typed in), tries to
delete the carbon row (refused: the plies are cut from it) and grabs the dialog.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from docs.shotkit import Shot

REPO = Path(__file__).resolve().parent.parent
CARBON = "carbon plain weave 200"


def main() -> int:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "docs/images/materials_dialog.png"
    shot = Shot()
    from flatweave.app.mainwindow import MainWindow
    from flatweave.document.project import new_project
    from flatweave.reading.examples import example_path, load_example

    win = MainWindow()
    win.resize(1600, 1000)
    win.move(0, 0)
    win.set_project(new_project(load_example("octant"), "octant", str(example_path("octant")), 0.04))
    win.show()
    shot.wait(lambda: win.view.is_ready() and win.pattern_view.is_ready())
    win.side_tabs.setCurrentWidget(win.pieces_panel)
    panel = win.pieces_panel
    panel.rename(0, "ply 1 (0)")
    panel.choose_material(CARBON)
    panel.duplicate_at(0, 45.0)
    panel.rename(1, "ply 2 (+45)")
    dialog = panel.open_materials()
    names = [f.name for f in dialog.table()]
    dialog.grid.selectRow(names.index(CARBON))
    dialog.add_copy()
    copy = names.index(CARBON) + 1
    dialog.edit_cell(copy, "name", "carbon plain weave 200 (supplier B)")
    dialog.edit_cell(copy, "roll", "1000")
    dialog.edit_cell(copy, "weight", "205")
    dialog.grid.selectRow(names.index(CARBON))
    dialog.delete_selected()  # refused: both plies are cut from it
    shot.settle(0.5)
    shot.save(dialog.grab(), out)
    print(f"wrote {out}: {dialog.width()}x{dialog.height()}, {dialog.status.text()}")
    dialog.reject()
    win.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
