"""View > Fibre angle shows what the fibre-angle CSV exports."""

from __future__ import annotations

import numpy as np

from flatweave.export.registry import ExportOptions, export_all
from tests.test_app_run import run_to_end, small_project
from tests.test_fibres import read_csv


def test_the_windows_fibre_map_is_the_csvs(qtbot, make_window, tmp_path):
    win = make_window(small_project(0.1, angle_deg=30.0))
    run_to_end(qtbot, win)
    r = win.document.project.result
    win.actions["mode_fibre"].trigger()
    qtbot.wait(50)
    head, table = read_csv(export_all(r, [tmp_path / "p.csv"], ExportOptions())[0])
    csv_dev = table[:, list(head).index("deviation_deg")]
    for view in (win.view, win.pattern_view):  # the surface and the pattern colour the same cells
        shown = np.asarray(view.layer.cells.cell_data["value"])
        assert len(shown) == len(csv_dev) == len(r.mesh.cells)
        np.testing.assert_allclose(shown, csv_dev, atol=1e-9, equal_nan=True)
    assert np.nanmax(np.abs(csv_dev)) > 1.0  # at 30 degrees on the octant the threads turn from the rosette
