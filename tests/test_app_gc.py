"""Cyclic garbage is collected in the GUI thread while a window is open (decision 0073): garbage
made by a worker thread (as the nesting and solve threads make it) is freed by the GUI thread's
timer, never in the worker, and the automatic collector comes back when the last window closes."""

from __future__ import annotations

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


def test_garbage_made_in_a_worker_is_collected_in_the_gui_thread(make_window, qtbot):
    was = gc.isenabled()
    win = make_window(example="octant")
    assert not gc.isenabled()  # while a window is open the automatic collector is off
    _Cycle.freed_in.clear()

    def work():
        for _ in range(20_000):  # far past the youngest generation's threshold: Python would collect here
            _Cycle()

    worker = threading.Thread(target=work, name="worker")
    worker.start()
    worker.join()
    qtbot.waitUntil(lambda: len(_Cycle.freed_in) >= 19_000, timeout=10000)  # the GUI thread's timer
    assert set(_Cycle.freed_in) == {threading.main_thread().name}
    win.close()
    assert gc.isenabled() == was  # the last window closed: the collector as it was
