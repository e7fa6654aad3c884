"""flatweave app: the desktop GUI (PySide6 + pyvista) on top of :mod:`core`.

:mod:`app.view3d`, :mod:`app.view2d`, :mod:`app.viewbase` and :mod:`app.canvas`
are the only modules that touch pyvista or VTK; :mod:`app.mainwindow` holds the window,
menus and actions, :mod:`app.tools` the 3D view's tools; :mod:`app.main` is
the ``flatweave`` command.
"""

import sys


def _keep_none_alive() -> None:
    """Give ``None`` a reference count nothing can use up (CPython < 3.12 only).

    shiboken6 6.12.0 (PySide6 6.12.0, the only version our package index
    has) drops one reference to ``None`` on every call of a Qt method that
    returns nothing (``widget.update()``, ``QTimer.singleShot``,
    ``processEvents``...): measured, ``sys.getrefcount(None)`` falls by one
    per call, and by about 550 per solve in the window. When it reaches zero
    CPython 3.11 aborts the process ("none_dealloc: deallocating None"): about
    130 solves into a session, or at once in a loop that pumps events. From
    3.12 on, ``None`` is immortal and its count is never checked; here we do
    the same by hand, once: ``None`` is a static object that is never freed,
    so a count of 2**60 changes nothing else.
    """
    if sys.implementation.name != "cpython" or sys.version_info >= (3, 12):
        return
    import ctypes

    count = ctypes.c_ssize_t.from_address(id(None))  # ob_refcnt, the first field of every PyObject
    if count.value < 2 ** 60:
        count.value += 2 ** 60


_keep_none_alive()
