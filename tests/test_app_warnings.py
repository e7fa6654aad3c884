"""The window tells a result's warnings and colours every metric against its limit."""

from __future__ import annotations

from dataclasses import replace

import pytest

from flatweave.reading.examples import load_example
from flatweave.method.lattice import MATERIALS
from flatweave.method.metrics import metric_limits
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import flatten
from flatweave.document.project import Project

from flatweave.app.panels import METRIC_COLOURS, metric_colour


def test_metric_colours_follow_the_limits():
    limits = metric_limits(MATERIALS["woven"], 15.0, 30.0)
    warn, bad = limits["max_shear_deg"]
    assert (warn, bad) == (15.0, 30.0)
    assert [metric_colour(v, (warn, bad)) for v in (14.9, 15.0, 15.1, 30.0, 30.1)] == [
        METRIC_COLOURS[0], METRIC_COLOURS[0], METRIC_COLOURS[1], METRIC_COLOURS[1], METRIC_COLOURS[2]]


@pytest.fixture(scope="module")
def budget_result():
    """The octant stopped by its iteration budget: a result the pipeline warns about."""
    surface = load_example("octant")
    return surface, flatten(surface, FlattenSettings(spacing=0.1, max_iter=2))


def _colour(label) -> str:
    sheet = label.styleSheet()
    return sheet.split("color:")[1].split(";")[0].strip() if "color:" in sheet else ""


def test_a_result_with_warnings_says_so_and_why(budget_result, make_window):
    surface, result = budget_result
    assert result.warnings and any("before it converged" in w for w in result.warnings), result.warnings
    win = make_window(project=Project(surface, result.settings, name="octant", result=result))
    panel = win.metrics
    assert panel.text("status").endswith(", with warnings"), panel.text("status")
    assert panel.warnings == result.warnings  # the project's angles are the defaults the pipeline used
    assert "before it converged" in panel.text("warnings")
    m = result.metrics
    limits = metric_limits(result.settings.material)
    for key, name in panel.LIMITED:
        assert _colour(panel.labels[key]) == metric_colour(m[name], limits[name]), key
    assert panel.text("uncovered") == f"{m['uncovered_pct']:.2f} %"


def test_the_shear_angles_of_the_project_decide_the_shear_warning(budget_result, make_window):
    surface, result = budget_result
    shear = result.metrics["max_shear_deg"]
    # a lock angle below the result's largest shear: shear is now past it, in red, and warned about
    tight = Project(surface, result.settings, name="octant", result=result,
                    shear_warning_deg=shear / 4, shear_limit_deg=shear / 2)
    win = make_window(project=tight)
    panel = win.metrics
    assert _colour(panel.labels["shear"]) == METRIC_COLOURS[2]
    assert any("lock" in w for w in panel.warnings), panel.warnings
    # and within generous angles there is no shear warning and the number is green
    loose = replace(tight, shear_warning_deg=shear + 1, shear_limit_deg=shear + 2)
    win.set_project(loose)
    assert _colour(panel.labels["shear"]) == METRIC_COLOURS[0]
    assert not any("lock" in w for w in panel.warnings)


def test_the_window_shows_every_warning_and_the_core_status(make_window):
    """The Warnings cell lists what the CLI prints, and the Status cell is the result's status:
    a dome stopped by its budget, sheared past the lock angle, is not usable, in red."""
    dome = load_example("dome")
    result = flatten(dome, FlattenSettings(spacing=0.1, max_iter=1))
    assert not result.usable and len(result.warnings) >= 2, (result.status, result.warnings)
    assert any("lock angle" in w for w in result.warnings) and any("budget" in w for w in result.warnings)
    win = make_window(project=Project(dome, result.settings, name="dome", result=result))
    panel = win.metrics
    assert panel.warnings == result.warnings
    assert panel.text("warnings") == "\n".join(result.warnings)
    assert panel.text("status") == result.status
    assert "pattern not usable: shear" in panel.text("status")
    assert _colour(panel.labels["status"]) == METRIC_COLOURS[2]
