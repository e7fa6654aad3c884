"""flatweave app: the desktop GUI (PySide6 + pyvista) on top of :mod:`core`.

:mod:`app.view3d` is the only module that touches pyvista or VTK;
:mod:`app.mainwindow` holds the window, menus and actions; :mod:`app.main`
is the ``flatweave`` command.
"""
