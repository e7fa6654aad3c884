"""The registries and shared pieces of the core: the solver list, the dart
kinds' protocol, settings that check themselves and their one encoding, and
the shared numerics."""

import json
import math

import numpy as np
import pytest

from flatweave.geometry import numerics as geom
from flatweave.cli import build_parser
from flatweave.method.darts import (CUT_DART_KEYS, DART_KINDS, RESULT_DART_KEYS, CurveDart, Dart, PlaneDart,
                                    dart_from_dict)
from flatweave.method.energy import YarnConstraint
from flatweave.errors import SettingsError, SolverError
from flatweave.method.lattice import Material
from flatweave.method.settings import FlattenSettings
from flatweave.method.settings import settings_to_dict
from flatweave.document.project import ProjectError, _Fields, settings_from_dict
from flatweave.method.solvers import (solvers, method_names, solver_entry, solver_help, solver_label,
                                      solver_labels, solver_names)


# ---------------------------------------------------------------------- solvers
def test_the_solver_lists_come_from_the_registry():
    assert solver_names("spring") == ("fast", "paper", "none")
    assert solver_names("spring", iterative=True) == ("fast", "paper")
    assert solver_names("planar") == ("planar",) and method_names() == ("spring", "planar")
    assert solver_labels("spring", iterative=True) == {"fast": "fast (Levenberg-Marquardt)",
                                                       "paper": "paper (steepest descent + CG)"}
    assert solver_label("none") == "none (the drape only)"
    assert all(e.run is not None for e in solvers() if e.target is not None)
    from flatweave.studies.planar import flatten_planar
    assert solver_entry("planar").run is flatten_planar and solver_entry("none").run is None


def test_the_cli_builds_its_choices_and_help_from_the_registry():
    sub = build_parser()._subparsers._group_actions[0].choices["flatten"]
    acts = {a.dest: a for a in sub._actions}
    assert acts["solver"].choices == ("fast", "paper", "none") and acts["solver"].default == "fast"
    assert acts["solver"].help == solver_help("spring") == (
        "fast (Levenberg-Marquardt, default), paper (steepest descent + Fletcher-Reeves CG with golden-section "
        "search) or none (the initial drape only)")
    assert acts["method"].choices == ("spring", "planar") and "--solver fast|none" in acts["method"].help


# ---------------------------------------------------------------------- darts
PLANE = PlaneDart((1.0, 0.0, 0.0, -0.55), (0.5, 1.0, 0.0, 1.0, 0.0, 0.6), name="side", visible=False)
CURVE = CurveDart(np.array([[0.05, 0.8], [0.3, 0.75], [0.45, 0.7]]), name="curve",
                  handles=np.array([[0.05, 0.8], [0.45, 0.7]]), view_dir=(0.0, 0.0, 2.0))


@pytest.mark.parametrize("dart", [PLANE, CURVE], ids=["plane", "curve"])
def test_dart_kinds_round_trip_through_their_file_form(dart):
    assert isinstance(dart, Dart) and DART_KINDS[dart.kind] is type(dart)
    d = json.loads(json.dumps(dart.to_dict()))
    back = dart_from_dict(d, _Fields("test"), "darts[0]")
    assert json.dumps(back.to_dict()) == json.dumps(dart.to_dict())
    assert list(dart.to_dict(RESULT_DART_KEYS)) == [k for k in RESULT_DART_KEYS if k in dart.to_dict()]
    assert "name" not in dart.to_dict(CUT_DART_KEYS) and "visible" not in dart.to_dict(RESULT_DART_KEYS)


def test_dart_flags_replace_branches_on_the_kind():
    assert PLANE.needs_xyz and PLANE.has_widget and not PLANE.editable_points
    assert not CURVE.needs_xyz and not CURVE.has_widget and CURVE.editable_points


def test_a_bad_dart_entry_is_one_line_naming_it():
    with pytest.raises(ProjectError, match=r"darts\[2\]\.kind must be 'plane' or 'curve', got 'spiral'"):
        dart_from_dict({"kind": "spiral"}, _Fields("p"), "darts[2]")
    with pytest.raises(ProjectError, match=r"p: darts\[0\]: plane dart"):
        dart_from_dict({"kind": "plane", "plane": [0, 0, 0, 1]}, _Fields("p"), "darts[0]")


# ---------------------------------------------------------------------- settings
@pytest.mark.parametrize("kw, words", [
    (dict(spacing=-1.0), "spacing must be a positive number"),
    (dict(spacing=0.1, spacing_warp=math.nan), "warp spacing must be a positive number"),
    (dict(spacing=0.1, seed=(0.5, 1.5)), "seed must be two fractions"),
    (dict(spacing=0.1, angle_deg=math.inf), "weft angle must be a number"),
    (dict(spacing=0.1, paths="spiral"), "paths must be 'plane' or 'geodesic'"),
    (dict(spacing=0.1, solver="newton"), "solver 'newton' is not one of fast, paper, none"),
    (dict(spacing=0.1, tol=0.0), "tolerance must be a positive number"),
    (dict(spacing=0.1, max_iter=-1), "max iterations must be a non-negative integer"),
    (dict(spacing=0.1, max_seconds=-1.0), "time budget"),
    (dict(spacing=0.1, max_nodes=0), "max nodes must be a positive integer"),
    (dict(spacing=0.1, darts=("x",)), "darts must be PlaneDart or CurveDart"),
])
def test_settings_check_themselves_when_made(kw, words):
    with pytest.raises(SettingsError, match=words):
        FlattenSettings(**kw)


def test_one_encoding_of_the_settings_for_result_and_project_files():
    s = FlattenSettings(spacing=0.1, material=Material("custom", 300.0, 200.0, 5.0), max_seconds=5.0,
                        darts=(PLANE, CURVE), yarns=(YarnConstraint("warp", 0, (0.0, 1.0, -1.0, 0.0), 50.0),))
    r = settings_to_dict(s, "result")
    assert list(r) == ["spacing", "spacing_warp", "material", "seed", "angle_deg", "paths", "solver", "tol",
                       "max_iter", "max_seconds", "yarns", "darts", "max_nodes"]
    assert r["spacing_warp"] == 0.1 and r["darts"][1] == {"kind": "curve", "name": "curve", "uv": CURVE.uv.tolist()}
    p = settings_to_dict(s, "project")
    assert p["spacing_warp"] is None and "darts" not in p
    back = settings_from_dict(p, [d.to_dict() for d in s.darts], [y.to_dict() for y in s.yarns])
    assert settings_to_dict(back, "result") == r


# ---------------------------------------------------------------------- numerics
def test_shared_numerics():
    rng = np.random.default_rng(1)
    x, y = rng.standard_normal((5, 3)), rng.standard_normal((5, 3))
    assert np.array_equal(geom.rowdot(x, y), x[:, 0] * y[:, 0] + x[:, 1] * y[:, 1] + x[:, 2] * y[:, 2])
    line = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    p = np.array([[0.5, 0.5], [2.0, 0.5], [-1.0, 0.0]])
    assert np.allclose(geom.polyline_distance(p, line), [0.5, 1.0, 1.0])
    assert geom.nearest_segment(p, line).tolist() == [0, 1, 0]
    assert np.allclose(geom.resample_at_lengths(line, line, np.array([0.5, 1.5])), [[0.5, 0.0], [1.0, 0.5]])
    e = geom.outline_errors(1.1, 1.0, 0.9, 1.0)
    assert e["boundary_error_signed_pct"] == pytest.approx(10.0) and e["area_error_pct"] == pytest.approx(10.0)
    with pytest.raises(SolverError, match=r"^the result's nodes is NaN at 1 of 2 nodes; the solve stopped"):
        geom.require_finite("the result's nodes", np.array([[0.0, np.nan], [1.0, 2.0]]), "nodes")
