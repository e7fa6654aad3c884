"""What the window says is true of what it shows: the hover text of another document, a strain
scale stretched to numerical noise, an energy plot that has nothing to draw."""

from __future__ import annotations

import numpy as np
import pytest

from flatweave.app.colours import GREEN, STRAIN_NOISE_PCT, ramp, strain_range, strain_stops
from flatweave.app.plot import NO_SOLVE
from flatweave.app.viewbase import DIAGONAL, SCALE_TITLES, THREAD
from flatweave.reading.examples import example_path
from flatweave.document.project import new_project
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.method.metrics import spring_strain
from tests.test_app_recovery import click, write_orphan
from tests.test_app_run import run_to_end, small_project


# ---------------------------------------------------------------------- hover
def _hover_a_spring(win) -> str:
    """Move the mouse (a real VTK event) over a weft spring in the middle of the piece; the hover text."""
    r = win.project.result
    view = win.view
    view.render_now()
    weft = np.flatnonzero(r.mesh.kind == 0)
    mid = 0.5 * (r.xyz[r.mesh.ends[weft, 0]] + r.xyz[r.mesh.ends[weft, 1]])
    x, y = view.display_point(mid[np.argmin(np.linalg.norm(mid - r.xyz.mean(axis=0), axis=1))])
    iren = view.plotter.iren.interactor
    iren.SetEventInformation(int(round(x)), int(round(y)), 0, 0)
    view._last_pick = 0.0
    iren.InvokeEvent("MouseMoveEvent")
    return win._hover_label.text()


@pytest.mark.slow
@pytest.mark.parametrize("how", ["example", "open", "recover"])
def test_the_hover_text_goes_with_its_document(make_window, qtbot, tmp_path, how):
    win = make_window(small_project(0.1))
    run_to_end(qtbot, win)
    text = _hover_a_spring(win)
    assert "weft spring" in text and win.view.hover_text == text
    if how == "example":
        assert win.open_example("cone")
    elif how == "open":
        assert win.open_file(example_path("saddle"))
    else:
        folder = tmp_path / "crash"
        write_orphan(folder, small_project(0.12), "other piece")
        win.check_recovery(folder)
        click(win.recovery_box, "Recover")
        assert win.document.project.name == "other piece"
    assert win._hover_label.text() == ""
    # the next move over the same spot reports afresh (the view does not think it said so already)
    assert win.view.hover_text is None and win.pattern_view.hover_text is None


# ---------------------------------------------------------------------- the strain scale's floor
def test_a_strain_scale_does_not_stretch_below_the_noise_floor():
    assert strain_range(np.array([-3e-11, 1e-11])) == (-STRAIN_NOISE_PCT, STRAIN_NOISE_PCT)
    assert strain_range(np.array([-0.129, 0.0442])) == (-0.129, 0.0442)  # the octant's threads: their own ends
    assert strain_range(np.array([5e-4, 0.3])) == (-STRAIN_NOISE_PCT, 0.3)
    # noise is painted as what it is: green
    rgb = ramp(np.array([-3e-11, 1e-11]), strain_stops(*strain_range(np.array([-3e-11, 1e-11]))))
    np.testing.assert_allclose(rgb, [GREEN, GREEN], atol=1e-8)


def test_a_developable_piece_is_painted_green(make_window, qtbot):
    """The half cylinder converges with strains of 4e-5 % (the bent springs' precision, decision 0057):
    every spring green, each colour bar over the noise floor, not over the noise."""
    win = make_window(example="half_cylinder")
    run_to_end(qtbot, win)
    r = win.project.result
    pct = 100 * spring_strain(r.xyz, r.mesh)
    assert np.abs(pct).max() < 1e-2 * STRAIN_NOISE_PCT  # the case in point: noise only
    _, rgb = win.view.layer.spring_colours()
    assert np.abs(rgb.astype(int) - [0, 255, 0]).max() <= 1
    bars = dict(win.view.colour_bars)
    assert bars[SCALE_TITLES[THREAD]] == pytest.approx((-STRAIN_NOISE_PCT, STRAIN_NOISE_PCT))
    assert bars[SCALE_TITLES[DIAGONAL]] == pytest.approx((-STRAIN_NOISE_PCT, STRAIN_NOISE_PCT))
    _, rgb2 = win.pattern_view.layer.spring_colours()
    np.testing.assert_array_equal(rgb2, rgb)


# ---------------------------------------------------------------------- the energy plot
def _plot_texts(win) -> list[str]:
    plot = win.energy_plot
    plot.grab()  # paints it
    return [text for text, _ in plot.text_rects]


@pytest.mark.slow
def test_the_energy_plot_says_a_solve_converged_at_its_start(make_window, qtbot, tmp_path):
    win = make_window(example=None)
    assert NO_SOLVE in _plot_texts(win)
    # a flat sheet: its drape is its minimum (a curved developable piece's drape lays chords, which its
    # solve bends into arcs in a few iterations)
    P = np.array([[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]], dtype=float)
    win.set_project(new_project(NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], P), "flat sheet", "flat", 0.1))
    run_to_end(qtbot, win)
    r = win.project.result
    assert r.metrics["iterations"] == 0 and r.metrics["solver_status"] == "converged" and len(r.history) == 0
    assert "converged at the start: 0 iterations" in _plot_texts(win)
    assert NO_SOLVE not in _plot_texts(win)
    # the same from the stored result, reopened
    path = tmp_path / "flat.flatweave"
    assert win.save_to(path)
    other = make_window(example=None)
    assert other.open_file(path)
    assert "converged at the start: 0 iterations" in _plot_texts(other)
    # and a document without a result has had no solve
    assert other.open_example("cone")
    assert NO_SOLVE in _plot_texts(other)
