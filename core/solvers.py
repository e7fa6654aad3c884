"""The solvers a user can choose: one list the CLI, the GUI and the docs read.

Each :class:`SolverEntry` names a solver, says how to show it (``label`` in
the GUI, ``description`` in the CLI's help), which method family it belongs
to (``"spring"``: the paper's spring mesh, :mod:`core.pipeline`; ``"planar"``:
the comparison method of :mod:`core.planar`) and where the function that runs
it lives. A new solver is one entry here plus its module.

The functions are named as ``"module:attribute"`` and imported on first use,
so reading the list (the CLI's parser, ``--help``) imports no numerics and
the solver modules can read the list without an import cycle.

* spring family, iterative (``run`` is a generator ``run(_Run)`` of
  :mod:`core.solver` yielding snapshots): ``fast``, ``paper``;
* spring family, ``none``: no solver, the drape only (``run`` is None);
* planar family: ``planar``, run by :func:`core.planar.flatten_planar`; its
  own minimisers are chosen with the spring family's ``--solver`` names
  through ``solver_map`` (fast -> "lm", none -> "none").
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field

__all__ = ["SolverEntry", "SOLVER_REGISTRY", "FAMILIES", "DEFAULT_SOLVER", "solver_entry", "solver_names",
           "solver_label", "solver_labels", "solver_help", "method_names", "method_help"]


@dataclass(frozen=True)
class SolverEntry:
    """name : what settings, files and the CLI call it
    label : how the GUI shows it
    description : one line for the CLI's help
    family : "spring" or "planar"
    target : "module:function" that runs it, or None (nothing to run)
    solver_map : planar family only: ``--solver`` name -> the method's own minimiser
    """

    name: str
    label: str
    description: str
    family: str
    target: str | None
    solver_map: dict = field(default_factory=dict)

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


SOLVER_REGISTRY: tuple[SolverEntry, ...] = (
    SolverEntry("fast", "fast (Levenberg-Marquardt)", "Levenberg-Marquardt", "spring",
                "core.solver:_iterate_fast"),
    SolverEntry("paper", "paper (steepest descent + CG)",
                "steepest descent + Fletcher-Reeves CG with golden-section search", "spring",
                "core.solver:_iterate_paper"),
    SolverEntry("none", "none (the drape only)", "the initial drape only", "spring", None),
    SolverEntry("planar", "planar (Wang, Smith and Yuen 2002)",
                "the planar energy method of Wang, Smith and Yuen 2002 the paper compares against: "
                "triangles laid flat and relaxed in the plane", "planar", "core.planar:flatten_planar",
                solver_map={"fast": "lm", "none": "none"}),
)

FAMILIES = ("spring", "planar")
"""Method families, the spring mesh (the paper's method, the default) first."""

DEFAULT_SOLVER = "fast"

_BY_NAME = {e.name: e for e in SOLVER_REGISTRY}


def solver_entry(name: str) -> SolverEntry:
    """The registry entry called ``name`` (KeyError if there is none)."""
    return _BY_NAME[name]


def solver_names(family: str | None = "spring", iterative: bool | None = None) -> tuple[str, ...]:
    """Names in registry order: of one family (None: all), optionally only the
    iterative minimisers (``iterative=True``) or only the others."""
    return tuple(e.name for e in SOLVER_REGISTRY
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
             for e in SOLVER_REGISTRY if e.family == family]
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
