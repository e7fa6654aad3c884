"""flatweave.app: the desktop window (PySide6 + pyvista) over the engine, :mod:`flatweave`.

:mod:`~flatweave.app.view3d`, :mod:`~flatweave.app.view2d`, :mod:`~flatweave.app.viewbase` and
:mod:`~flatweave.app.canvas` are the only modules that touch pyvista or VTK;
:mod:`~flatweave.app.mainwindow` holds the window, which puts together its parts
(:mod:`~flatweave.app.actions`, :mod:`~flatweave.app.presenter`, :mod:`~flatweave.app.files`,
:mod:`~flatweave.app.exporting`, :mod:`~flatweave.app.runcontrol`, :mod:`~flatweave.app.tooling`);
:mod:`~flatweave.app.tools` holds the 3D view's tools; :mod:`~flatweave.app.main` is the
``flatweave`` command (also ``python -m flatweave.app``).
"""
