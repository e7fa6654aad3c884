"""A third-party solver is one registry entry and a generator over the public
:class:`flatweave.method.solver.Run`: the pipeline, the CLI, the settings' checks
and the project's re-runs take it up and ask its declaration, never its name.

(The toy reader and exporter are in tests/test_registries.py, the toy window
tool in tests/test_app_registries.py.)
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from flatweave.cli import main
from flatweave.document.project import new_project, warm_start
from flatweave.errors import SettingsError
from flatweave.method.darts import PlaneDart
from flatweave.method.energy import Energy
from flatweave.method.pipeline import flatten
from flatweave.method.settings import FlattenSettings
from flatweave.method.solvers import SolverEntry, register_solver, solver_names, unregister_solver
from flatweave.reading.examples import load_example

TOY = SolverEntry("toy", "toy (gradient descent)", "plain gradient descent with backtracking", "spring",
                  "tests.test_extension_points:toy_descent", warm_start=False, coarse_start=False,
                  darts=False, yarns=False)


def toy_descent(run):
    """Gradient descent in (u, v) with a halving step: the smallest solver the
    :class:`~flatweave.method.solver.Run` contract allows."""
    surface = run.problem.surface
    dom = surface.domain
    step = 1e-3 * float(np.min(dom[:, 1] - dom[:, 0]))
    while True:
        if not run.budget_left():
            return
        energy = Energy(surface, run.mesh, run.terms)
        E, g = energy.value_and_grad(run.uv)
        run.nfev += 1
        t = step / max(float(np.abs(g).max()), 1e-300)
        for _ in range(40):  # halve until the energy falls
            trial = run.uv - t * g
            E_new = energy.value_xyz(surface.points(trial))
            run.nfev += 1
            if E_new < E:
                break
            t /= 2
        else:
            run.status, run.message = 0, "converged"
            return
        run.nit += 1
        changed = run.remove_invalid(run.uv, trial)
        xyz = surface.points(run.uv)
        yield run.snapshot(Energy(surface, run.mesh, run.terms).value_xyz(xyz), xyz, changed)
        if not changed and E - E_new <= run.options.tol * E:
            run.status, run.message = 0, "converged"
            return


@pytest.fixture
def toy():
    register_solver(TOY)
    yield TOY
    unregister_solver("toy")


def test_a_registered_solver_runs_through_the_pipeline(toy):
    surface = load_example("octant")
    drape = flatten(surface, FlattenSettings(spacing=0.1, solver="none"))
    result = flatten(surface, FlattenSettings(spacing=0.1, solver="toy", max_iter=25))
    assert result.settings.solver == "toy"
    assert 0 < result.metrics["iterations"] <= 25
    assert result.metrics["energy"] < drape.metrics["energy"]  # it really minimised (plain descent is slow)
    assert result.mesh.n_nodes == drape.mesh.n_nodes


def test_a_registered_solver_is_a_cli_choice(toy, tmp_path, capsys):
    out = tmp_path / "r.json"
    assert main(["flatten", "octant", "--spacing", "0.1", "--solver", "toy", "--max-iter", "10",
                 "--quiet", "--out", str(out)]) == 0
    saved = json.loads(out.read_text())
    assert saved["settings"]["solver"] == "toy" and 0 < saved["metrics"]["iterations"] <= 10
    with pytest.raises(SystemExit):
        main(["flatten", "--help"])
    assert "toy (plain gradient descent with backtracking)" in " ".join(capsys.readouterr().out.split())


def test_the_pipeline_asks_the_declaration_for_a_coarse_start(toy, monkeypatch):
    """The same solver declared able to start coarse-to-fine is started so on a large
    piece; declared unable, it is not (the name is never asked)."""
    surface = load_example("octant")
    settings = dict(spacing=0.02, max_iter=3)  # about 4,000 nodes: past the coarse start's threshold
    plain = flatten(surface, FlattenSettings(solver="toy", **settings))
    assert plain.metrics.get("coarse_levels", 0) == 0
    unregister_solver("toy")
    register_solver(dataclasses.replace(TOY, coarse_start=True))
    coarse = flatten(surface, FlattenSettings(solver="toy", **settings))
    assert coarse.metrics["coarse_levels"] >= 1


def test_darts_and_yarns_are_refused_for_a_solver_that_declares_it_cannot(toy):
    dart = PlaneDart(plane=(1.0, 0.0, 0.0, 0.0))
    with pytest.raises(SettingsError, match="does not cut darts"):
        FlattenSettings(spacing=0.1, solver="toy", darts=(dart,))
    FlattenSettings(spacing=0.1, solver="fast", darts=(dart,))  # the built-in one does


def test_a_solver_without_warm_start_redrapes(toy):
    surface = load_example("octant")
    project = new_project(surface, "p")
    fast = dataclasses.replace(project.settings, spacing=0.1)
    done = dataclasses.replace(project, settings=fast, result=flatten(surface, fast))
    assert warm_start(done) is not None
    toy_settings = dataclasses.replace(fast, solver="toy", max_iter=5)
    assert warm_start(dataclasses.replace(done, settings=toy_settings)) is None


def test_registration_is_checked_and_undone(toy):
    with pytest.raises(SettingsError, match="already registered"):
        register_solver(TOY)
    with pytest.raises(SettingsError, match="family"):
        register_solver(dataclasses.replace(TOY, name="other", family="origami"))
    with pytest.raises(SettingsError, match="built-in"):
        unregister_solver("fast")
    assert "toy" in solver_names("spring")


def test_the_toy_is_gone_after_the_fixture():
    assert "toy" not in solver_names("spring")
    with pytest.raises(SettingsError, match="not one of"):
        FlattenSettings(spacing=0.1, solver="toy")
