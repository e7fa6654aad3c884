"""The choices the command and the panels offer: the views' render widgets
(``--view`` / ``FLATWEAVE_VIEW``) and the solvers.

No Qt or VTK here: the command checks its options before it loads either, and
:mod:`flatweave.app.canvas` and :mod:`flatweave.app.panels` read the same lists.
"""

from __future__ import annotations
from flatweave.method.solvers import solver_labels as labels

__all__ = ["VIEW_KINDS", "view_setting", "solver_labels"]

VIEW_KINDS = ("auto", "gl", "canvas")


def view_setting(text: str | None) -> str:
    """One of VIEW_KINDS from ``--view`` or ``FLATWEAVE_VIEW`` (None or blank: auto);
    anything else raises ValueError with a one-line message."""
    view = (text or "").strip().lower() or "auto"
    if view not in VIEW_KINDS:
        raise ValueError(f"FLATWEAVE_VIEW must be one of {', '.join(VIEW_KINDS)}, not {view!r}")
    return view


def solver_labels() -> dict[str, str]:
    """The iterative solvers of the paper's spring method by name, with the settings
    panel's label of each (``--solver``'s choices), from :mod:`flatweave.method.solvers`."""

    return labels("spring", iterative=True)
