"""Make docs/images/seam_picker.png and docs/images/seam_sleeve.png: a sleeve-shaped mesh opened along a seam.

    xvfb-run -s '-screen 0 1600x1000x24' .venv/bin/python docs/seam_screenshot.py [OUT_DIR]

Writes a binary STL of a sleeve (a cone frustum open at both ends, radius 50 mm
at the cuff end, 35 mm at the other, 150 mm long: developable, so its pattern is
an exact annulus sector), opens it with File > Open's code path (the picker
starts drawing a seam), puts two points on the line along its near side, grabs
the picker, presses OK, solves the piece opened along that seam and grabs the
window.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from docs.shotkit import Shot

REPO = Path(__file__).resolve().parent.parent
R0, R1, L = 50.0, 35.0, 150.0


def sleeve(n: int = 96, m: int = 60):
    """The frustum's triangles: n round, m along."""
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    z = np.linspace(0, L, m)
    T, Z = np.meshgrid(t, z, indexing="ij")
    r = R0 + (R1 - R0) * Z / L
    V = np.column_stack([(r * np.cos(T)).ravel(), (r * np.sin(T)).ravel(), Z.ravel()])
    idx = np.arange(n * m).reshape(n, m)
    nxt = np.roll(idx, -1, axis=0)
    a, b, c, d = idx[:, :-1].ravel(), nxt[:, :-1].ravel(), nxt[:, 1:].ravel(), idx[:, 1:].ravel()
    return V, np.r_[np.stack([a, b, c], 1), np.stack([a, c, d], 1)]


def main() -> int:
    import trimesh


    out = Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "docs/images"
    shot = Shot()
    wait = shot.wait
    path = Path(tempfile.mkdtemp()) / "sleeve.stl"
    path.write_bytes(trimesh.Trimesh(*sleeve(), process=False).export(file_type="stl"))
    win, picker = shot.picker_window(path)
    picker.move(0, 0)
    picker.resize(900, 700)
    picker.view.plotter.camera_position = [(300.0, -160.0, 180.0), (0.0, 0.0, L / 2), (0.0, 0.0, 1.0)]
    picker.view.plotter.reset_camera()
    for a, z in ((0.0, 3.0), (0.0, L - 3.0)):  # the seam along the near side, from end to end
        r = R0 + (R1 - R0) * z / L
        picker.add_point([r * np.cos(a - 0.35), r * np.sin(a - 0.35), z])
    picker.view.render_now()
    shot.settle(1.0)
    shot.save(picker.grab(), out / "seam_picker.png")
    picker.ok_button.click()
    wait(lambda: win.project is not None)
    shot.close_units_dialog(win)  # the units-and-fit dialog: its question is answered (mm) already
    wait(lambda: win.view.is_ready() and win.pattern_view.is_ready())
    shot.solve(win)
    win.view.reset_camera()
    win.pattern_view.fit()
    shot.settle(1.0)
    shot.save(win.grab(), out / "seam_sleeve.png")
    m = win.project.result.metrics
    print(f"wrote {out}/seam_picker.png, seam_sleeve.png: boundary error {m['boundary_error_signed_pct']:.4f} %, "
          f"area error {m['area_error_signed_pct']:.4f} %, {m['nodes']} nodes")
    win.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
