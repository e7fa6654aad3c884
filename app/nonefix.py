"""A guard for shiboken6 builds that drop a reference to ``None`` on every
call of a Qt method that returns nothing (seen with shiboken6 6.12.0).

On CPython before 3.12 ``None``'s count reaching zero aborts the process
("none_dealloc: deallocating None"); from 3.12 on ``None`` is immortal. No
fixed shiboken6 release is known, so every shiboken6 from 6.12 on gets the
guard on CPython < 3.12. The launcher and the test session call
:func:`keep_none_alive` before they make a QApplication. No Qt import here
beyond reading shiboken6's version.
"""

from __future__ import annotations

import sys

__all__ = ["keep_none_alive", "needs_none_guard", "FIRST_AFFECTED"]

FIRST_AFFECTED = (6, 12)  # the first shiboken6 known to drop None references
_BIG = 2 ** 60


def needs_none_guard(implementation: str, python: tuple, shiboken: tuple | None) -> bool:
    """True when this interpreter and shiboken6 version (None: not installed) need the guard."""
    if shiboken is None or implementation != "cpython" or tuple(python[:2]) >= (3, 12):
        return False
    return tuple(shiboken[:2]) >= FIRST_AFFECTED


def _shiboken_version() -> tuple | None:
    try:
        import shiboken6
    except ImportError:
        return None
    return tuple(int(x) for x in shiboken6.__version_info__[:3])


def keep_none_alive() -> bool:
    """Give ``None`` a reference count nothing can use up, when this process
    needs it (see the module docstring); True if it has one now. ``None`` is a
    static object that is never freed, so a count of 2**60 changes nothing
    else. Safe to call more than once."""
    if not needs_none_guard(sys.implementation.name, sys.version_info, _shiboken_version()):
        return False
    import ctypes

    count = ctypes.c_ssize_t.from_address(id(None))  # ob_refcnt, the first field of every PyObject
    if count.value < _BIG:
        count.value += _BIG
    return True
