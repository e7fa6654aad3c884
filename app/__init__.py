"""flatweave app: the desktop GUI (PySide6 + pyvista) on top of :mod:`core`.

:mod:`app.view3d`, :mod:`app.view2d`, :mod:`app.viewbase` and :mod:`app.canvas`
are the only modules that touch pyvista or VTK; :mod:`app.mainwindow` holds the
window, which puts together its parts (:mod:`app.actions`, :mod:`app.presenter`,
:mod:`app.files`, :mod:`app.exporting`, :mod:`app.runcontrol`,
:mod:`app.tooling`); :mod:`app.tools` holds the 3D view's tools; :mod:`app.main`
is the ``flatweave`` command.
"""
