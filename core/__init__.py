"""flatweave core: the headless engine.

Surfaces, spring mesh, drape, energy, solvers, darts, pattern, metrics, files
and the CLI. Never imports Qt, VTK or pyvista.
"""

__version__ = "0.1.0"
