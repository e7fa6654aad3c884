"""The bundled example job files (TOML: a laminate's plies), installed as the package
``flatweave.example_jobs``.

The files are data (read by :mod:`flatweave.reading.jobs`, found by
:func:`flatweave.reading.examples.job_path`); this module makes the folder a regular
package so :mod:`importlib.resources` finds it in a wheel.
"""
