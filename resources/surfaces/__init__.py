"""The bundled example surfaces, installed as the package ``flatweave.examples_data``.

The files are data (read by :mod:`flatweave.reading.examples`); this module makes the folder
a regular package so :mod:`importlib.resources` finds it in a wheel.
"""
