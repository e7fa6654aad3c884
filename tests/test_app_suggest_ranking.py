"""Tools > Suggest darts and Solve > Best orientation rank by what the designer
sees: a dart that would ruin the pattern is not listed, a piece within every
warning limit gets none and the dialog says why, and the sweep's table says
which rows' patterns are usable."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from PySide6.QtWidgets import QDialogButtonBox

import flatweave.app.suggest as suggest_dialog
import flatweave.studies.autodarts as autodarts
from flatweave.reading.examples import example_path, load_example
from flatweave.document.project import new_project
from tests.test_app_run import run_to_end

TIMEOUT_MS = 120000


def _project(name, spacing, **settings):
    p = new_project(load_example(name), name, str(example_path(name)), spacing)
    return p.with_settings(**settings) if settings else p


def _suggest(qtbot, win):
    """Open the dialog (it suggests up to 2 darts at once) and wait for its outcome on screen."""
    win.actions["suggest_darts"].trigger()
    box = win.suggest_box
    # the button comes back with the outcome, after the thread has ended
    qtbot.waitUntil(lambda: not box.busy and box.suggest_button.isEnabled(), timeout=TIMEOUT_MS)
    return box


@pytest.mark.slow
def test_darts_that_would_open_gaps_in_the_saddle_are_not_listed(qtbot, make_window):
    """The saddle's strongest candidates lower the energy by 85 % and leave over 3 % of it
    uncovered (not usable); the dialog lists only darts whose patterns are usable."""
    win = make_window(_project("saddle", 0.2))
    run_to_end(qtbot, win)
    assert win.document.project.result.usable and win.document.project.result.warnings
    box = _suggest(qtbot, win)
    assert box.list.count() == len(box.proposals) >= 1
    for k, p in enumerate(box.proposals):
        assert p.result.usable and p.metrics["uncovered_pct"] <= 0.5, p.result.status
        assert "(usable" in box.list.item(k).text()


def test_a_piece_within_every_warning_limit_gets_no_dart_and_the_dialog_says_why(qtbot, make_window):
    win = make_window(_project("garment", 0.05))
    run_to_end(qtbot, win)
    assert win.document.project.result.warnings == ()
    box = _suggest(qtbot, win)
    assert box.list.count() == 0 and box.proposals == []
    assert box.status.text() == "No dart suggested: every metric is within its warning limits: no dart needed."
    assert not box.buttons.button(QDialogButtonBox.StandardButton.Apply).isEnabled()


@pytest.mark.slow
def test_a_ruinous_dart_beside_a_good_one_is_not_listed(qtbot, make_window, monkeypatch):
    """Two candidates: one lowers the energy by 26 % but doubles the outline (the report's
    'boundary 153 %'), the other lowers it by 15 % and clears the shear warning, its
    outline a little longer (within its limit)."""
    from flatweave.method.darts import CurveDart
    from flatweave.method.lattice import MATERIALS
    from flatweave.method.result import judged

    good = CurveDart(np.array([[0.0, 0.5], [0.3, 0.5]]), name="good")
    ruin = CurveDart(np.array([[1.0, 0.5], [0.7, 0.5]]), name="ruin")
    material = replace(MATERIALS["woven"], warn_deg=5.0)  # the octant's 9.5 deg shear warns
    win = make_window(_project("octant", 0.1, material=material))
    run_to_end(qtbot, win)
    base = win.document.project.result
    e0 = base.metrics["energy"]

    def solve(job):
        _surface, settings, _state = job
        ruined = np.array_equal(settings.darts[-1].uv, ruin.uv)
        changes = ({"energy": 0.743 * e0, "boundary_error_pct": 153.0, "area_error_pct": 55.0} if ruined
                   else {"energy": 0.85 * e0, "max_shear_deg": 4.0,
                         "boundary_error_pct": base.metrics["boundary_error_pct"] + 1.0})
        return judged(replace(base, settings=settings, metrics={**base.metrics, **changes}))

    real = autodarts.suggest_darts
    monkeypatch.setattr(autodarts, "candidate_darts", lambda result, sites, lengths=None: [(0, ruin), (1, good)])
    monkeypatch.setattr(autodarts, "_solve", solve)
    # the stubs live in this process: solve here, not in worker processes
    monkeypatch.setattr(suggest_dialog, "suggest_darts", lambda result, count: real(result, count=count, workers=1))
    box = _suggest(qtbot, win)
    assert box.list.count() == 1
    assert np.array_equal(box.proposals[0].dart.uv, good.uv)
    text = box.list.item(0).text()
    assert "energy -15.0 %" in text and "(usable, within every limit)" in text
    assert box.status.text().endswith(
        "No more: every metric is within its warning limits with 1 suggested dart: no further dart needed.")


def test_best_orientation_says_which_patterns_are_usable(qtbot, make_window):
    from flatweave.app.sweepdialog import COLUMNS

    win = make_window(_project("dome", 0.15))
    win.settings_panel.auto_rerun.setChecked(False)
    box = win.sweep_dialog()
    box.angles.setValue(2)
    box.go.click()
    qtbot.waitUntil(lambda: not box.busy and box.table.rowCount() == 2, timeout=TIMEOUT_MS)
    col = [c[0] for c in COLUMNS].index("unusable")
    assert box.table.horizontalHeaderItem(col).text() == "pattern"
    texts = [box.table.item(i, col).text() for i in range(2)]
    # 45 degrees first: at 0 the dome's corners shear past the lock angle
    assert [r["angle_deg"] for r in box.result.rows] == [45.0, 0.0]
    assert texts[0] == "usable" and texts[1].startswith("not usable: shear ")
    assert "ranked by the pattern's usability" in box.status.text()
