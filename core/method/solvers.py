"""The solvers a user can choose: one list the CLI, the GUI and the docs read.

Each :class:`SolverEntry` names a solver, says how to show it (``label`` in
the GUI, ``description`` in the CLI's help), which method family it belongs
to (``"spring"``: the paper's spring mesh, :mod:`flatweave.method.pipeline`; ``"planar"``:
the comparison method of :mod:`flatweave.studies.planar`) and where the function that runs
it lives. A new solver is one entry here plus its module.

Each entry also declares what its solver can do (``warm_start``,
``coarse_start``, ``darts``, ``yarns``); the pipeline, the settings' checks and
the project's re-runs ask the declaration, never the name. A new solver is
one :func:`register_solver` call (tests/test_extension_points.py adds one).

The functions are named as ``"module:attribute"`` and imported on first use,
so reading the list (the CLI's parser, ``--help``) imports no numerics and
the solver modules can read the list without an import cycle.

* spring family, iterative (``run`` is a generator ``run(Run)`` over
  :class:`flatweave.method.solver.Run` yielding snapshots): ``fast``, ``paper``;
* spring family, ``none``: no solver, the drape only (``run`` is None);
* planar family: ``planar``, run by :func:`flatweave.studies.planar.flatten_planar`; its
  own minimisers are chosen with the spring family's ``--solver`` names
  through ``solver_map`` (fast -> "lm", none -> "none").
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field

from flatweave.errors import SettingsError

__all__ = ["SolverEntry", "register_solver", "unregister_solver", "solvers", "FAMILIES", "DEFAULT_SOLVER",
           "solver_entry", "solver_names",
           "solver_label", "solver_labels", "solver_help", "method_names", "method_help"]


@dataclass(frozen=True)
class SolverEntry:
    """name : what settings, files and the CLI call it
    label : how the GUI shows it
    description : one line for the CLI's help
    family : "spring" or "planar"
    target : "module:function" that runs it, or None (nothing to run)
    solver_map : planar family only: ``--solver`` name -> the method's own minimiser
    warm_start : it can continue from a saved result's mesh (a re-run after an edit)
    coarse_start : the pipeline may start it coarse-to-fine (:mod:`flatweave.method.multilevel`)
        on a large piece without darts
    darts : it honours darts (a run of one that does not is refused when darts are set)
    yarns : it honours yarn constraints (likewise)
    """

    name: str
    label: str
    description: str
    family: str
    target: str | None
    solver_map: dict = field(default_factory=dict)
    warm_start: bool = True
    coarse_start: bool = False
    darts: bool = True
    yarns: bool = True

    @property
    def iterative(self) -> bool:
        """A spring-family minimiser (a generator of snapshots), not 'none' or another family."""
        return self.family == "spring" and self.target is not None

    @property
    def run(self):
        """The function that runs this solver (imported on first use), or None."""
        if self.target is None:
            return None
        module, _, attr = self.target.partition(":")
        return getattr(importlib.import_module(module), attr)


_BUILTIN = (
    SolverEntry("fast", "fast (Levenberg-Marquardt)", "Levenberg-Marquardt", "spring",
                "flatweave.method.solver:iterate_fast", coarse_start=True),
    # the paper's scheme is the reference the fast solver is measured against: it starts from the drape
    SolverEntry("paper", "paper (steepest descent + CG)",
                "steepest descent + Fletcher-Reeves CG with golden-section search", "spring",
                "flatweave.method.solver:iterate_paper"),
    SolverEntry("none", "none (the drape only)", "the initial drape only", "spring", None),
    SolverEntry("planar", "planar (Wang, Smith and Yuen 2002)",
                "the planar energy method of Wang, Smith and Yuen 2002 the paper compares against: "
                "triangles laid flat and relaxed in the plane", "planar", "flatweave.studies.planar:flatten_planar",
                solver_map={"fast": "lm", "none": "none"}, warm_start=False, yarns=False),
)

FAMILIES = ("spring", "planar")
"""Method families, the spring mesh (the paper's method, the default) first."""

DEFAULT_SOLVER = "fast"

_BY_NAME: dict[str, SolverEntry] = {e.name: e for e in _BUILTIN}


def register_solver(entry: SolverEntry) -> None:
    """Add a solver (a ``SettingsError`` names a taken name or an unknown family). Its
    function is found by ``entry.target`` on first use; a spring-family solver is a
    generator ``solve(run)`` over :class:`flatweave.method.solver.Run`."""
    if not isinstance(entry, SolverEntry):
        raise SettingsError(f"register_solver takes a SolverEntry, got {type(entry).__name__}")
    if entry.name in _BY_NAME:
        raise SettingsError(f"a solver named {entry.name!r} is already registered")
    if entry.family not in FAMILIES:
        raise SettingsError(f"solver family {entry.family!r} is not one of {', '.join(FAMILIES)}")
    _BY_NAME[entry.name] = entry


def unregister_solver(name: str) -> None:
    """Remove a solver added by :func:`register_solver` (the built-in ones stay)."""
    if name in {e.name for e in _BUILTIN}:
        raise SettingsError(f"{name!r} is a built-in solver")
    _BY_NAME.pop(name, None)


def solvers() -> list[SolverEntry]:
    """Every registered solver, in registration order."""
    return list(_BY_NAME.values())


def solver_entry(name: str) -> SolverEntry:
    """The registry entry called ``name`` (KeyError if there is none)."""
    return _BY_NAME[name]


def solver_names(family: str | None = "spring", iterative: bool | None = None) -> tuple[str, ...]:
    """Names in registry order: of one family (None: all), optionally only the
    iterative minimisers (``iterative=True``) or only the others."""
    return tuple(e.name for e in _BY_NAME.values()
                 if (family is None or e.family == family) and (iterative is None or e.iterative == iterative))


def solver_label(name: str) -> str:
    """The GUI's label of solver ``name``."""
    return _BY_NAME[name].label


def solver_labels(family: str | None = "spring", iterative: bool | None = None) -> dict[str, str]:
    """name -> label, in registry order (for a combo box)."""
    return {n: _BY_NAME[n].label for n in solver_names(family, iterative)}


def solver_help(family: str = "spring", default: str = DEFAULT_SOLVER) -> str:
    """``--solver`` help: 'fast (Levenberg-Marquardt, default), paper (...) or none (...)'."""
    parts = [f"{e.name} ({e.description}{', default' if e.name == default else ''})"
             for e in _BY_NAME.values() if e.family == family]
    return ", ".join(parts[:-1]) + " or " + parts[-1] if len(parts) > 1 else "".join(parts)


def method_names() -> tuple[str, ...]:
    """The ``--method`` choices: the families that have a solver."""
    return tuple(f for f in FAMILIES if solver_names(f))


def method_help() -> str:
    """``--method`` help, from the families' entries."""
    planar = solver_entry("planar")
    accepted = "|".join(planar.solver_map)
    return (f"spring (the paper's method, default) or planar ({planar.description}; uses --spacing as edge "
            f"length, darts, --solver {accepted}, --tol, --max-iter, --max-seconds, --max-nodes)")
