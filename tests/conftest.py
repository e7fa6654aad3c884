"""Shared fixtures: the GUI tests' windows, and the solved octants the export tests read back."""

from __future__ import annotations

import os

import pytest


def pytest_configure(config):
    """The test session makes Qt calls as the app does: the same None guard first (flatweave.app.nonefix).
    Registers the ``slow`` mark: ``make test-fast`` (pytest -m "not slow") leaves those tests out."""
    from flatweave.app.nonefix import keep_none_alive

    config.addinivalue_line("markers", "slow: over about half a second on a 2-core machine (most window "
                            "tests, the bigger solves); left out by make test-fast (pytest -m \"not slow\")")
    keep_none_alive()


def _qt_test(fixturenames) -> bool:
    return bool({"qtbot", "qapp"} & set(fixturenames))


def destroy_closed_widgets() -> int:
    """Destroy, here in the GUI thread, what closed windows left: the deleteLater()s pytest-qt posts
    when it closes a test's widgets, then the cycles that held their Python wrappers. Returns what
    the collector freed. Left alone, a test's window is freed by the next automatic collection,
    in whatever thread allocates then (decision 0073): a later test's worker thread, with the
    collector back on once no window is open, destroying Qt and VTK objects off the GUI thread."""
    import gc

    from PySide6.QtCore import QCoreApplication, QEvent

    if QCoreApplication.instance() is not None:
        QCoreApplication.sendPostedEvents(None, QEvent.Type.DeferredDelete)
    return gc.collect()


@pytest.fixture(autouse=True)
def gc_in_the_gui_thread(request):
    """A Qt test runs as the app always does, with a window open: the cyclic collector in the GUI
    thread only (flatweave.app.gcguard), so a test of a dialog or a worker without a main window
    cannot have a worker thread free its Qt objects either. Set up before, torn down after, the
    test's other fixtures."""
    if not _qt_test(request.fixturenames):
        yield
        return
    from flatweave.app import gcguard

    request.getfixturevalue("qapp")
    gcguard.acquire()
    try:
        yield
    finally:
        gcguard.release()


@pytest.hookimpl(hookwrapper=True, tryfirst=True)
def pytest_runtest_protocol(item, nextitem):
    """After a Qt test has run and torn down (pytest-qt's closing of its widgets included, and pytest's
    letting go of the test's fixture values, which happens after the teardown hooks): its windows
    destroyed before the next test (:func:`destroy_closed_widgets`)."""
    yield
    if _qt_test(item.fixturenames):
        destroy_closed_widgets()


def open_plotters() -> set[str]:
    """pyvista registers every live plotter here (the check pyvistaqt's own tests make)."""
    from pyvista.plotting.plotter import _ALL_PLOTTERS
    return set(_ALL_PLOTTERS)


@pytest.fixture(autouse=True)
def recovery_dir(tmp_path_factory, monkeypatch):
    """Every test autosaves into a folder of its own, never the user's."""
    folder = tmp_path_factory.mktemp("recovery")
    monkeypatch.setenv("FLATWEAVE_RECOVERY_DIR", str(folder))
    return folder


@pytest.fixture(params=["canvas", "gl"])
def each_widget(request, monkeypatch):
    """Run a test with each of the views' render widgets (flatweave.app.canvas): the
    raster canvas (what this machine's software OpenGL gets) and pyvistaqt's
    OpenGL widget (what a GPU gets). Ask for it before any window fixture."""
    monkeypatch.setenv("FLATWEAVE_VIEW", request.param)
    return request.param


def check_widget_kind(win) -> None:
    """The views use the render widget FLATWEAVE_VIEW names (if it names one)."""
    from flatweave.app.canvas import CanvasPlotter, GLPlotter

    want = {"canvas": CanvasPlotter, "gl": GLPlotter}.get(os.environ.get("FLATWEAVE_VIEW", ""))
    if want is not None:
        for view in (win.view, win.pattern_view):
            assert isinstance(view.plotter, want), f"{type(view.plotter).__name__}, not {want.__name__}"


@pytest.fixture
def make_window(qtbot):
    """A factory of shown, ready main windows; fails if a window's plotters outlive it."""
    from flatweave.app.mainwindow import MainWindow

    before = open_plotters()
    made = []

    def make(project=None, example: str | None = "octant"):
        win = MainWindow()
        qtbot.addWidget(win)
        if project is not None:
            win.set_project(project)
        elif example is not None:
            assert win.open_example(example)
        win.show()
        qtbot.waitExposed(win)
        qtbot.waitUntil(lambda: win.view.is_ready() and win.pattern_view.is_ready(), timeout=10000)
        check_widget_kind(win)
        made.append(win)
        return win

    yield make
    for win in made:
        win.close()
    assert open_plotters() <= before, "a window's plotter was not closed"
    assert all(win.session is None for win in made), "a window's recovery session outlived it"


@pytest.fixture(scope="session")
def octant_dart():
    """The octant with a dart from the equator edge towards the pole (one piece)."""
    from flatweave.method.darts import PlaneDart
    from flatweave.reading.examples import load_example
    from flatweave.method.settings import FlattenSettings
    from flatweave.method.pipeline import flatten

    dart = PlaneDart((1.0, -1.0, 0.0, 0.0), (-2, 2, -2, 2, -2, 0.55), name="plane dart")
    return flatten(load_example("octant"), FlattenSettings(spacing=0.1, darts=(dart,)))


@pytest.fixture(scope="session")
def octant_cut():
    """The octant cut in two by the plane x = y (two pieces)."""
    from flatweave.method.darts import PlaneDart
    from flatweave.reading.examples import load_example
    from flatweave.method.settings import FlattenSettings
    from flatweave.method.pipeline import flatten

    dart = PlaneDart((1.0, -1.0, 0.0, 0.0), None, name="cut")
    return flatten(load_example("octant"), FlattenSettings(spacing=0.1, darts=(dart,)))
