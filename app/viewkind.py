"""The views' render widget setting (``--view`` / ``FLATWEAVE_VIEW``).

No Qt or VTK here: the command checks the setting before it loads either,
and :mod:`app.canvas` (which makes the widgets) reads it the same way.
"""

from __future__ import annotations

__all__ = ["VIEW_KINDS", "view_setting"]

VIEW_KINDS = ("auto", "gl", "canvas")


def view_setting(text: str | None) -> str:
    """One of VIEW_KINDS from ``--view`` or ``FLATWEAVE_VIEW`` (None or blank: auto);
    anything else raises ValueError with a one-line message."""
    view = (text or "").strip().lower() or "auto"
    if view not in VIEW_KINDS:
        raise ValueError(f"FLATWEAVE_VIEW must be one of {', '.join(VIEW_KINDS)}, not {view!r}")
    return view
