"""The GUI's Qt-free parts: colour scales, frames, and which modules may touch VTK."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from flatweave.app.colours import BLUE, GREEN, PURPLE, RED, YELLOW, ramp, shear_stops, strain_range, strain_stops
from flatweave.app.frames import FrameMaker
from flatweave.method.darts import CurveDart, DartSet, PlaneDart
from flatweave.reading.examples import load_example
from flatweave.method.lattice import DIAG
from flatweave.method.metrics import cell_shear_deg, spring_strain
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import flatten

REPO = Path(__file__).resolve().parents[1]


def test_strain_scale_is_the_papers():
    lo, hi = strain_range(np.array([-3.0, -1.0, 0.5, 6.0]))
    assert (lo, hi) == (-3.0, 6.0)
    stops = strain_stops(lo, hi)
    rgb = ramp(np.array([-3.0, -1.5, 0.0, 3.0, 6.0, 9.0, -9.0]), stops)
    np.testing.assert_allclose(rgb[0], BLUE)    # highest compressive: pure blue
    np.testing.assert_allclose(rgb[2], GREEN)   # zero: pure green
    np.testing.assert_allclose(rgb[4], RED)     # highest tensile: pure red
    np.testing.assert_allclose(rgb[1], [0.0, 0.5, 0.5])  # proportional in between
    np.testing.assert_allclose(rgb[3], [0.5, 0.5, 0.0])
    np.testing.assert_allclose(rgb[5], RED)     # clamped beyond the ends
    np.testing.assert_allclose(rgb[6], BLUE)
    # all tensile: zero is still green and the scale never collapses
    lo, hi = strain_range(np.array([0.0, 0.0]))
    assert lo < 0 < hi
    lo, hi = strain_range(np.array([1.0, 2.0, np.nan]))
    assert lo < 0 and hi == 2.0


def test_shear_scale_thresholds():
    stops = shear_stops(15.0, 30.0)
    rgb = ramp(np.array([0.0, 15.0, 30.0, 30.1, 44.0, 80.0]), stops)
    np.testing.assert_allclose(rgb[0], GREEN)
    np.testing.assert_allclose(rgb[1], YELLOW)
    np.testing.assert_allclose(rgb[2], RED)
    for k in (3, 4, 5):
        np.testing.assert_allclose(rgb[k], PURPLE)  # past the limit: one flat colour
    assert stops[-1][0] == 45.0


def test_nice_length():
    from flatweave.app.view2d import nice_length  # needs pyvista, not Qt windows

    assert nice_length(0.63) == 0.5 and nice_length(1.0) == 1.0 and nice_length(3.7) == 2.0
    assert nice_length(999.0) == 500.0 and nice_length(0.0123) == 0.01


@pytest.fixture(scope="module")
def dart_result():
    surface = load_example("octant")
    s = FlattenSettings(spacing=0.08, darts=(PlaneDart((1.0, 0.0, 0.0, -0.5), name="plane"),
                                             CurveDart(np.array([[0.02, 0.75], [0.25, 0.72], [0.4, 0.7]]),
                                                       name="curve")))
    return flatten(surface, s)


def test_frames_carry_the_results_own_numbers(dart_result):
    r = dart_result
    f = FrameMaker(r.surface, r.settings).from_result(r)
    np.testing.assert_array_equal(f.strain, spring_strain(r.xyz, r.mesh))
    np.testing.assert_array_equal(f.shear, cell_shear_deg(r.xyz, r.mesh))
    np.testing.assert_array_equal(f.boundary, np.flatnonzero(r.mesh.boundary_nodes()))
    np.testing.assert_array_equal(f.xy, r.pattern.xy)
    assert f.final and f.pattern is r.pattern and f.status == r.metrics["solver_status"]
    assert f.stats["boundary_error_pct"] == r.metrics["boundary_error_pct"]
    thread = r.mesh.kind != DIAG
    assert f.stats["max_thread_strain_pct"] == r.metrics["max_thread_strain_pct"] == pytest.approx(
        100 * np.abs(f.strain[thread]).max())


def test_frame_dart_nodes_are_the_cores(dart_result):
    """The k-d tree shortcut finds exactly the nodes core's rule finds."""
    r = dart_result
    maker = FrameMaker(r.surface, r.settings)
    f = maker.from_result(r)
    reach = float(np.hypot(r.mesh.r_weft, r.mesh.r_warp))
    labels = DartSet(r.surface, r.settings.darts).dart_nodes(maker.dart_curves(), r.uv, r.xyz, reach)
    pos = np.unique(np.concatenate([d["positive"] for d in labels]))
    neg = np.unique(np.concatenate([d["negative"] for d in labels]))
    assert len(pos) > 5 and len(neg) > 5
    np.testing.assert_array_equal(f.dart_positive, pos)
    np.testing.assert_array_equal(f.dart_negative, neg)
    assert len(f.dart_curves) == 2 and all(len(c) >= 2 for c in f.dart_curves)


def test_topology_ids_are_unique_across_makers(dart_result):
    r = dart_result
    a = FrameMaker(r.surface, r.settings).from_result(r)
    b = FrameMaker(r.surface, r.settings).from_result(r)
    m = FrameMaker(r.surface, r.settings)
    c1, c2 = m.from_result(r), m.from_result(r)
    assert a.topology != b.topology and c1.topology == c2.topology


VTK_NAMES = {"pyvista", "pyvistaqt", "vtk", "vtkmodules"}
VIEW_MODULES = {"view3d.py", "view2d.py", "viewbase.py", "canvas.py"}
QT_FREE = {"colours.py", "frames.py", "aspects.py", "choices.py"}


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


def test_only_the_views_touch_vtk():
    files = sorted((REPO / "app").glob("*.py"))
    assert {f.name for f in files} >= VIEW_MODULES | QT_FREE | {"mainwindow.py", "worker.py"}
    for f in files:
        used = _imports(f)
        if f.name not in VIEW_MODULES:
            assert not used & VTK_NAMES, f"{f.name} imports {used & VTK_NAMES}"
        if f.name in QT_FREE:
            assert not used & {"PySide6", "shiboken6", "superqt"}, f"{f.name} imports Qt"


def test_many_qt_calls_never_use_up_none():
    """shiboken6 6.12.0 drops a reference to None per call of a void Qt method;
    on CPython 3.11 the process aborted when the count reached zero (about
    70,000 calls in the window). The launcher's guard makes None's count
    inexhaustible: 300,000 such calls must leave the process alive."""
    code = ("from flatweave.app.nonefix import keep_none_alive\n"
            "keep_none_alive()\n"
            "from PySide6.QtCore import QCoreApplication, QObject\n"
            "a = QCoreApplication([])\n"
            "o = QObject()\n"
            "for _ in range(300_000):\n"
            "    o.setObjectName('x')\n"
            "print('alive')\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                          cwd=str(REPO))
    assert proc.returncode == 0 and proc.stdout.strip() == "alive", proc.stderr[-500:]


def test_the_none_guard_is_for_the_builds_that_need_it():
    from flatweave.app.nonefix import needs_none_guard

    assert needs_none_guard("cpython", (3, 11, 7), (6, 12, 0))
    assert needs_none_guard("cpython", (3, 10, 0), (6, 13, 1))  # no fixed release known yet
    assert not needs_none_guard("cpython", (3, 12, 0), (6, 12, 0))  # None is immortal
    assert not needs_none_guard("cpython", (3, 11, 7), (6, 11, 2))
    assert not needs_none_guard("pypy", (3, 11, 7), (6, 12, 0))
    assert not needs_none_guard("cpython", (3, 11, 7), None)


@pytest.mark.slow
def test_importing_app_leaves_none_alone():
    """The guard is the launcher's call, not a side effect of ``import app``."""
    code = ("import sys\n"
            "before = sys.getrefcount(None)\n"
            "import app, flatweave.app.mainwindow\n"
            "print(sys.getrefcount(None) < 2 ** 59)\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                          cwd=str(REPO))
    assert proc.returncode == 0 and proc.stdout.strip() == "True", proc.stderr[-500:]


def _app_imports(path: Path) -> set[str]:
    """The app modules ``path`` imports (anywhere in it)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("app."):
            names.add(node.module)
        elif isinstance(node, ast.Import):
            names |= {a.name for a in node.names if a.name.startswith("app.")}
    return names


def test_the_views_do_not_import_the_command():
    """flatweave.app.main imports the window (through flatweave.app.canvas); nothing it loads
    imports flatweave.app.main back."""
    for f in sorted((REPO / "app").glob("*.py")):
        if f.name != "main.py":
            assert "flatweave.app.main" not in _app_imports(f), f"{f.name} imports flatweave.app.main"


def test_every_core_aspect_has_a_flag():
    from flatweave.app.aspects import Aspect, aspects_of
    from flatweave.document.history import ASPECTS

    flags = [aspects_of([name]) for name in ASPECTS]
    assert len(set(flags)) == len(ASPECTS) and Aspect.NONE not in flags
    assert aspects_of(ASPECTS) == Aspect.SURFACE | Aspect.SETTINGS | Aspect.LABELS | Aspect.DISPLAY | \
        Aspect.RESULT | Aspect.NAME | Aspect.PIECES | Aspect.SEAMS | Aspect.PLAN
    assert aspects_of(frozenset()) == Aspect.NONE
    with pytest.raises(KeyError):
        aspects_of(["colour"])


def test_the_window_never_asks_what_the_tool_is():
    """Per-tool behaviour lives in the Tool classes (their layers, editor, edits)
    and the tool registry's rows (flatweave.app.tooling._TOOLS): no other module
    of the window names a particular tool or tool editor (so none can ask whether the
    active tool is one)."""
    from flatweave.app import tooleditors, tools

    named = {n for n, v in vars(tools).items() if isinstance(v, type) and issubclass(v, tools.Tool)}
    named |= {n for n, v in vars(tooleditors).items()
              if isinstance(v, type) and issubclass(v, tooleditors.ToolEditor)}
    named -= {"Tool", "ToolEditor", "PointsTool"}  # the bases, the contract every tool and editor follows
    assert {"CurveDartTool", "PlaneDartTool", "YarnTool", "PlaneEditor", "YarnEditor"} <= named
    for path in sorted((REPO / "app").glob("*.py")):
        if path.name in ("tools.py", "tooleditors.py"):
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        allowed = set()
        if path.name == "tooling.py":  # the registry's rows and their import
            for node in ast.walk(tree):
                if isinstance(node, (ast.ImportFrom, ast.AnnAssign)) and (
                        isinstance(node, ast.ImportFrom) or getattr(node.target, "id", "") == "_TOOLS"):
                    allowed |= {id(n) for n in ast.walk(node)}
        for node in ast.walk(tree):
            if id(node) in allowed:
                continue
            name = node.id if isinstance(node, ast.Name) else node.attr if isinstance(node, ast.Attribute) else \
                node.name if isinstance(node, ast.alias) else None
            assert name not in named, f"{path.name}:{node.lineno} names {name}"
