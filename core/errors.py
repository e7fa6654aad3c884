"""Exceptions of the flatweave core.

Every error a user can cause (a bad file, a bad option, a surface the method
cannot handle) is a :class:`FlatweaveError` whose message is one line naming
the problem; the CLI prints it and exits with status 2, the GUI shows it.
"""


class FlatweaveError(Exception):
    """Base class of user-facing errors: ``str(err)`` is one line."""


class SurfaceError(FlatweaveError, ValueError):
    """A surface file or surface definition is invalid."""


class SettingsError(FlatweaveError, ValueError):
    """A setting (spacing, seed, angle, material, ...) is invalid."""


class SolverError(FlatweaveError, ArithmeticError):
    """A solve cannot go on: a value became NaN or infinite (the energy, its
    gradient, a node's position, or the surface evaluated at a point of its
    domain). The message names what, at which iteration and why; no result
    is made, so nothing the user has is changed."""
