"""What a document change touched, as the app sees it: :class:`Aspect` flags.

:class:`flatweave.document.history.Change` names its aspects with strings (core has no
enum for them yet); :func:`aspects_of` is the one place that turns them into
flags, so a misspelt or new aspect fails here instead of being ignored.
No Qt here.
"""

from __future__ import annotations

import enum
from typing import Iterable

__all__ = ["Aspect", "aspects_of", "HISTORY", "WHOLE"]


class Aspect(enum.Flag):
    """The parts of a project a change can touch (see ``flatweave.document.history.ASPECTS``)."""

    NONE = 0
    SURFACE = enum.auto()
    SETTINGS = enum.auto()  # what a solve depends on
    LABELS = enum.auto()    # darts' names and visibility, a curve dart's drawn points: never a solve
    DISPLAY = enum.auto()   # units and shear angles
    RESULT = enum.auto()
    NAME = enum.auto()
    PIECES = enum.auto()    # the list of pieces: which is active, names, order, quantities, the others
    SEAMS = enum.auto()     # the shapes split by seams into panels: a seam drawn, moved, deleted, its options
    PLAN = enum.auto()      # the cut plan's settings: roll widths, gap, splices placed by hand, mirror pairs


_FROM_CORE = {"surface": Aspect.SURFACE, "settings": Aspect.SETTINGS, "labels": Aspect.LABELS,
              "display": Aspect.DISPLAY, "result": Aspect.RESULT, "name": Aspect.NAME, "pieces": Aspect.PIECES,
             "seams": Aspect.SEAMS, "plan": Aspect.PLAN}

HISTORY = frozenset({"undo", "redo"})  # causes that swap whole projects back
WHOLE = HISTORY | {"reset"}  # causes after which every view is refreshed


def aspects_of(names: Iterable[str]) -> Aspect:
    """The flags of core's aspect names; KeyError for a name the app does not know."""
    out = Aspect.NONE
    for name in names:
        out |= _FROM_CORE[name]
    return out
