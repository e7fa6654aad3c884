"""Make docs/images/scan_panel.png: a panel drawn on a real scan, cut out, fitted by default and solved.

    xvfb-run -s '-screen 0 1600x1000x24' .venv/bin/python docs/scan_screenshot.py [OUT_DIR]

Opens pymeshlab's face000.ply (a single-view range scan of a carved head, 166,259
triangles in 22 parts, millimetres; fetched once into the test data cache) with
File > Open's code path: the panel picker opens. Twelve points round the face
(as ``tests/test_real_scans.py`` draws them), OK, the units-and-fit dialog closed
(its guess, millimetres, taken), the weft spacing set to 1.5 mm in the settings
panel, solved, and the window grabbed; prints the fit and the errors for the
caption.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from docs.shotkit import Shot

REPO = Path(__file__).resolve().parent.parent


def main() -> int:
    from flatweave.geometry.meshfit import clean_mesh
    from flatweave.reading.meshes import read_mesh
    from tests.helpers import package_file
    from tests.test_real_scans import front_loop

    out = Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "docs/images"
    shot = Shot()
    wait = shot.wait
    scan = package_file("pymeshlab", "2025.7.post1", "rangemaps/face000.ply")
    win, picker = shot.picker_window(scan)
    V, F, _ = clean_mesh(*read_mesh(scan), scan.name, 0)
    centre = 0.5 * (V.min(axis=0) + V.max(axis=0))
    for p in front_loop(V, centre[:2], 30.0, n=12):
        picker.add_point(np.asarray(p, dtype=float))
    picker.ok_button.click()
    wait(lambda: win.project is not None)
    shot.close_units_dialog(win)  # the units-and-fit dialog: its guess (mm) is the scan's unit
    wait(lambda: win.view.is_ready() and win.pattern_view.is_ready())
    spacing = win.settings_panel.spacing
    spacing.setText("1.5")
    spacing.editingFinished.emit()
    shot.solve(win)
    win.view.reset_camera()
    win.pattern_view.fit()
    shot.settle(1.0)
    shot.save(win.grab(), out / "scan_panel.png")
    r = win.project.result
    fit = win.project.surface.fit
    m = r.metrics
    print(f"wrote {out}/scan_panel.png: fit largest {100 * fit.max_deviation / fit.size:.3f} % mean "
          f"{100 * fit.mean_deviation / fit.size:.4f} % of {fit.size:.1f} mm; boundary error "
          f"{m['boundary_error_pct']:.3f} %, area error {m['area_error_pct']:.3f} %, {m['nodes']} nodes, "
          f"{m['iterations']} iterations, status {r.status!r}")
    win.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
