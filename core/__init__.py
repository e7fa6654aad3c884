"""flatweave: flat cutting patterns for woven fabric and isotropic sheets.

The engine's public API. Lengths are in the surface's model units (the file's
units, or metres for a unit-less mesh), angles in degrees, times in seconds::

    import flatweave

    opened = flatweave.open_path("octant")             # a file, or a bundled example's name
    settings = flatweave.FlattenSettings(spacing=0.05)  # mesh spacing in model units
    result = flatweave.flatten(opened.surface, settings)
    print(result.status, result.metrics["boundary_error_pct"])
    flatweave.export_file(result, "octant.dxf", flatweave.ExportOptions(units="m"))

:func:`open_path` returns an :class:`Opened` (surface, region, units, ...);
:func:`flatten` returns a :class:`FlattenResult` (the relaxed mesh, the
pattern, metrics, warnings and a status); a trimmed piece's region goes in
``FlattenSettings(region=opened.region, ...)``. Errors a user can cause are
:class:`FlatweaveError` subclasses with a one-line message.

The stages live in sub-packages (docs/ARCHITECTURE.md): ``reading``,
``geometry``, ``method``, ``studies``, ``export``, ``document``; the window is
``flatweave.app``. Each extension point has one registry: readers
(:func:`register_reader`), solvers (:func:`flatweave.method.solvers.register_solver`),
exporters (:func:`register_exporter`).

The names load on first use (module ``__getattr__``, PEP 562), so that a
sub-package's import (``import flatweave.reading.cad`` in the CAD reader's
child process) does not load the whole engine first.
"""

import importlib

from flatweave.version import __version__

# public name -> (module, name there)
_API = {
    "Project": ("flatweave.document.project", "Project"),
    "load_project": ("flatweave.document.project", "load_project"),
    "new_project": ("flatweave.document.project", "new_project"),
    "save_project": ("flatweave.document.project", "save_project"),
    "FlatweaveError": ("flatweave.errors", "FlatweaveError"),
    "SettingsError": ("flatweave.errors", "SettingsError"),
    "SolverError": ("flatweave.errors", "SolverError"),
    "SurfaceError": ("flatweave.errors", "SurfaceError"),
    "ExportOptions": ("flatweave.export.registry", "ExportOptions"),
    "exporters": ("flatweave.export.registry", "exporters"),
    "register_exporter": ("flatweave.export.registry", "register_exporter"),
    "export_file": ("flatweave.export.registry", "export"),
    "NurbsSurface": ("flatweave.geometry.nurbs", "NurbsSurface"),
    "Region": ("flatweave.geometry.region", "Region"),
    "CurveDart": ("flatweave.method.darts", "CurveDart"),
    "PlaneDart": ("flatweave.method.darts", "PlaneDart"),
    "YarnConstraint": ("flatweave.method.energy", "YarnConstraint"),
    "MATERIALS": ("flatweave.method.lattice", "MATERIALS"),
    "Material": ("flatweave.method.lattice", "Material"),
    "flatten": ("flatweave.method.pipeline", "flatten"),
    "flatten_iter": ("flatweave.method.pipeline", "flatten_iter"),
    "FlattenResult": ("flatweave.method.result", "FlattenResult"),
    "FlattenSettings": ("flatweave.method.settings", "FlattenSettings"),
    "Opened": ("flatweave.reading.opened", "Opened"),
    "open_path": ("flatweave.reading.registry", "open_path"),
    "readers": ("flatweave.reading.registry", "readers"),
    "register_reader": ("flatweave.reading.registry", "register_reader"),
}

__all__ = ["__version__", *_API]


def __getattr__(name: str):
    if name not in _API:
        raise AttributeError(f"module 'flatweave' has no attribute {name!r}")
    module, attr = _API[name]
    value = getattr(importlib.import_module(module), attr)
    globals()[name] = value  # once loaded, an ordinary attribute
    return value


def __dir__():
    return sorted(set(globals()) | set(_API))
