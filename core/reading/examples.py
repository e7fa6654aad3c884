"""The bundled example surfaces (``resources/surfaces``).

``resources/surfaces/index.json`` lists every example; it and the surface
files are written by ``resources/make_surfaces.py``. The folder is installed
as the package data of ``flatweave.examples_data`` (see ``pyproject.toml``), so an
installed wheel finds it with :mod:`importlib.resources`; a source checkout
reads the folder itself. Each entry is a dict with the keys

- ``name``, ``file``, ``title``, ``description``, ``units`` (str)
- ``exact_area``, ``exact_boundary_length`` : float, or None without a closed form
- ``reference_area``, ``reference_boundary_length`` : float, independent
  high-accuracy quadrature (see ``reference_method``)
- ``area_formula``, ``boundary_formula`` : str or None
- ``recommended_spacing`` : float, mesh spacing in ``units``
- ``developable`` : bool; ``parameters`` : dict of the construction's numbers
"""

from __future__ import annotations

import copy
import importlib.resources
import json
from functools import lru_cache
from pathlib import Path

from flatweave.errors import SettingsError
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.geometry.surface_json import load_surface

__all__ = ["resources_dir", "surfaces_dir", "list_examples", "example_names", "example_info", "example_path",
           "load_example", "jobs_dir", "job_names", "job_path"]


def resources_dir() -> Path:
    """The source checkout's ``resources/`` folder, beside the ``core`` folder that installs as ``flatweave``
    (an installed wheel has only its ``surfaces``: see :func:`surfaces_dir`)."""
    return Path(__file__).resolve().parents[2] / "resources"


@lru_cache(maxsize=1)
def surfaces_dir() -> Path:
    """The folder of the example surfaces and ``index.json``.

    The checkout's ``resources/surfaces`` when flatweave runs from a source tree
    (which is also where an editable install points), else the installed
    package data ``flatweave.examples_data``. The checkout comes first so that a
    second checkout (a git worktree) reads its own files, not those of the
    checkout the environment's editable install points to.
    """
    checkout = resources_dir() / "surfaces"
    if (checkout / "index.json").is_file():
        return checkout
    return Path(str(importlib.resources.files("flatweave.examples_data")))


@lru_cache(maxsize=1)
def _index() -> tuple[dict, ...]:
    path = surfaces_dir() / "index.json"
    doc = json.loads(path.read_text(encoding="utf-8"))
    return tuple(doc["examples"])


def list_examples() -> list[dict]:
    """Every example's index entry (fresh copies), in the index's order."""
    return [copy.deepcopy(e) for e in _index()]


def example_names() -> list[str]:
    """Names of the bundled examples, e.g. ``['cone', 'octant', ...]``."""
    return [e["name"] for e in _index()]


def example_info(name: str) -> dict:
    """Index entry of example ``name``; :class:`SettingsError` if there is none."""
    for e in _index():
        if e["name"] == name:
            return copy.deepcopy(e)
    raise SettingsError(f"unknown example {name!r}; choose one of: {', '.join(example_names())}")


def example_path(name: str) -> Path:
    """Path of the surface file of example ``name``; :class:`SettingsError` if unknown."""
    return surfaces_dir() / example_info(name)["file"]


def load_example(name: str) -> NurbsSurface:
    """The surface of example ``name``."""
    return load_surface(example_path(name))


@lru_cache(maxsize=1)
def jobs_dir() -> Path:
    """The folder of the example job files: the checkout's ``resources/jobs``, else the
    installed package data ``flatweave.example_jobs`` (as :func:`surfaces_dir`)."""
    checkout = resources_dir() / "jobs"
    if checkout.is_dir() and any(checkout.glob("*.toml")):
        return checkout
    return Path(str(importlib.resources.files("flatweave.example_jobs")))


def job_names() -> list[str]:
    """Names of the bundled example jobs (their files' stems), e.g. ``['dome-laminate']``."""
    return sorted(p.stem for p in jobs_dir().glob("*.toml"))


def job_path(name: str) -> Path:
    """Path of the bundled job ``name`` (with or without ``.toml``); SettingsError if there is none."""
    stem = name[:-5] if name.lower().endswith(".toml") else name
    if stem not in job_names():
        raise SettingsError(f"unknown example job {name!r}; the bundled ones: {', '.join(job_names())}")
    return jobs_dir() / f"{stem}.toml"
