"""Cyclic garbage is collected in the GUI thread while a window is open (decision 0073): garbage
made by a worker thread (as the nesting and solve threads make it) is freed by the GUI thread's
timer, never in the worker, and the automatic collector comes back when the last window closes."""

from __future__ import annotations

import functools
import gc
import threading

import pytest

pytestmark = pytest.mark.slow  # a window


class _Cycle:
    """An object in a reference cycle that says which thread freed it."""

    freed_in: list = []

    def __init__(self):
        self.me = self

    def __del__(self):
        _Cycle.freed_in.append(threading.current_thread().name)


def _threads_freeing_a_workers_garbage(qtbot) -> set[str]:
    """Make cyclic garbage in a worker thread and wait until it is freed: the threads that freed it."""
    _Cycle.freed_in.clear()

    def work():
        for _ in range(20_000):  # far past the youngest generation's threshold: Python would collect here
            _Cycle()

    worker = threading.Thread(target=work, name="worker")
    worker.start()
    worker.join()
    qtbot.waitUntil(lambda: len(_Cycle.freed_in) >= 19_000, timeout=10000)  # the GUI thread's timer
    return set(_Cycle.freed_in)


def test_garbage_made_in_a_worker_is_collected_in_the_gui_thread(make_window, qtbot):
    was = gc.isenabled()
    win = make_window(example="octant")
    assert not gc.isenabled()  # while a window is open the automatic collector is off
    assert _threads_freeing_a_workers_garbage(qtbot) == {threading.main_thread().name}
    win.close()
    assert gc.isenabled() == was  # the last window closed: the collector as it was


def test_a_qt_test_without_a_window_collects_in_the_gui_thread_too(qtbot):
    """The harness (tests/conftest.py) runs every Qt test as the app always runs, a window open: a
    dialog's or a worker's test made without a main window gets no collection in a worker thread."""
    assert not gc.isenabled()
    assert _threads_freeing_a_workers_garbage(qtbot) == {threading.main_thread().name}


def _qt_and_vtk_garbage() -> list[str]:
    """The types of Qt, VTK, pyvista and flatweave.app objects a collection now would free."""
    gc.set_debug(gc.DEBUG_SAVEALL)
    try:
        gc.collect()
        kinds = [f"{type(o).__module__}.{type(o).__name__}" for o in gc.garbage]
    finally:
        gc.garbage.clear()
        gc.set_debug(0)
    return [k for k in kinds if k.startswith(("PySide6", "vtkmodules", "pyvista", "pyvistaqt", "flatweave.app"))]


def _ready(win) -> bool:
    return win.view.is_ready() and win.pattern_view.is_ready()


def test_a_closed_window_is_destroyed_in_the_gui_thread_before_the_next_test(qtbot):
    """What pytest-qt leaves of a test's window, closed and its deletion posted, is destroyed by the
    harness (tests/conftest.py) before the next test: Qt deletes it and nothing of it is left to
    the next automatic collection, which could come in another test's worker thread."""
    import weakref

    import shiboken6

    from flatweave.app.mainwindow import MainWindow
    from tests.conftest import destroy_closed_widgets

    win = MainWindow()
    assert win.open_example("octant")
    win.show()
    qtbot.waitUntil(functools.partial(_ready, win), timeout=10000)
    win.close()
    win.deleteLater()  # as pytest-qt closes a test's widgets
    ref = weakref.ref(win)
    del win
    assert ref() is not None and shiboken6.isValid(ref())  # closing deleted nothing: that waits for an event loop
    destroy_closed_widgets()
    left = ref()
    assert left is None or not shiboken6.isValid(left)  # Qt has deleted it...
    del left
    assert _qt_and_vtk_garbage() == []  # ...and the collection came after: nothing of it waits for the next
