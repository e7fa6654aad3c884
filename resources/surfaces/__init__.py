"""The bundled example surfaces, installed as the package ``core.examples_data``.

The files are data (read by :mod:`core.examples`); this module makes the folder
a regular package so :mod:`importlib.resources` finds it in a wheel.
"""
