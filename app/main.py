"""``flatweave``: the desktop app's command.

    flatweave [FILE] [--spacing R] [--solver fast|paper] [--run]
              [--screenshot OUT.png] [--quit] [--size WxH] [--timeout S]
              [--view auto|gl|canvas]

FILE is a project (``.flatweave``) or a surface (geomdl JSON); with none the
app opens the sphere-octant example. ``--run`` starts a solve once the window
is up; ``--screenshot`` saves an image of the window once it has rendered
(after the solve, with ``--run``); ``--quit`` exits after that. Together they
make the scripted mode used for documentation and smoke tests::

    flatweave SURFACE.json --run --screenshot OUT.png --quit

which exits 0, or 1 with a one-line message when the solve fails or takes
longer than ``--timeout``; a file that cannot be read exits 2. ``--view``
(or ``FLATWEAVE_VIEW``) picks the views' render widget, see :mod:`flatweave.app.canvas`.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from flatweave.app.choices import VIEW_KINDS, solver_labels, view_setting  # no Qt or VTK: checked before either loads
from flatweave.reading.registry import open_path
from flatweave.app.nonefix import keep_none_alive
from flatweave.cli import LENGTH, SECONDS, OneLineParser  # the command line's one-line refusals and ranges
from flatweave.errors import FlatweaveError, SettingsError

DEFAULT_EXAMPLE = "octant"
READY_POLL_MS = 50
READY_TIMEOUT_MS = 10000


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(x) for x in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size {text!r} must be WIDTHxHEIGHT, e.g. 1600x1000") from None
    if not (200 <= w <= 10000 and 200 <= h <= 10000):
        raise argparse.ArgumentTypeError(f"size {text!r} must be between 200x200 and 10000x10000")
    return w, h


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="flatweave",
        description="Flat cutting patterns for fabric covering NURBS surfaces (desktop app).")
    parser.add_argument("file", nargs="?", type=Path, metavar="FILE",
                        help="project (.flatweave), surface (geomdl JSON, STEP, IGES) or mesh (STL, OBJ, PLY, OFF); "
                             "a file of several faces opens the face picker; default: the sphere-octant example")
    parser.add_argument("--spacing", type=LENGTH, default=None, metavar="R",
                        help="mesh spacing for a surface (default: the example's, or about sqrt(area)/25)")
    parser.add_argument("--solver", choices=tuple(solver_labels()), default=None, help="solver to use")
    parser.add_argument("--run", action="store_true", help="solve once the window is up")
    parser.add_argument("--screenshot", type=Path, metavar="OUT.png",
                        help="save an image of the window once it has rendered (after the solve with --run)")
    parser.add_argument("--quit", action="store_true",
                        help="quit after start-up (after the solve and the screenshot, if any)")
    parser.add_argument("--size", type=_size, default=None, metavar="WxH", help="window size in pixels")
    parser.add_argument("--timeout", type=SECONDS, default=600.0, metavar="S",
                        help="with --run --quit: give up (status 1) after S seconds (default 600)")
    parser.add_argument("--view", choices=VIEW_KINDS, default=None,
                        help="render widget of the views: pyvistaqt's OpenGL widget (gl), a raster canvas "
                             "(canvas), or by the OpenGL renderer (auto: canvas on a software renderer); "
                             "default: $FLATWEAVE_VIEW or auto")
    return parser


def load_start_project(args):
    """What to open: (project, its path or None, None), or (None, None, opened)
    for a file whose piece is chosen in the window first (a STEP or IGES file of
    several faces, a mesh that needs or is advised a panel drawn on it), as File
    > Open does. ``--spacing`` and ``--solver`` apply to a project opened here."""

    opened = open_path(args.file if args.file is not None else DEFAULT_EXAMPLE)
    if opened.project is None and _chosen_in_window(opened):
        if args.run:
            raise SettingsError(f"{opened.path.name}: the piece is chosen in the window first; "
                                f"drop --run (or flatten it with flatweave-cli and --face / --region)")
        return None, None, opened
    project = opened.as_project()
    path = opened.path if opened.project is not None else None
    if args.spacing is not None:
        project = project.with_settings(spacing=args.spacing)
    if args.solver is not None:
        project = project.with_settings(solver=args.solver)
    return project, path, None


def _chosen_in_window(opened) -> bool:
    if opened.cad is not None:
        return opened.face is None
    mesh = opened.mesh
    return mesh is not None and (opened.surface is None or bool(mesh.advice))


def open_start(window, project, path, opened) -> None:
    """Show :func:`load_start_project`'s answer in ``window``: the project, or the
    face or panel picker over an empty window."""
    if project is not None:
        window.set_project(project, path)
    elif opened.cad is not None:
        window.files.pick_face(opened)
    else:
        window.files.pick_mesh_region(opened)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        view = view_setting(args.view or os.environ.get("FLATWEAVE_VIEW"))
    except ValueError as exc:
        print(f"flatweave: error: {exc}", file=sys.stderr)
        return 2
    if args.view:
        os.environ["FLATWEAVE_VIEW"] = view

    keep_none_alive()  # before any Qt call

    # Load before any Qt work: a bad file is a one-line error, status 2.

    try:
        project, project_path, to_pick = load_start_project(args)
    except (FlatweaveError, OSError) as exc:
        print(f"flatweave: error: {exc}", file=sys.stderr)
        return 2

    from PySide6.QtCore import QTimer
    from PySide6.QtWidgets import QApplication

    from flatweave.app.mainwindow import MainWindow  # Qt and VTK load once the arguments, view and file are known

    app = QApplication.instance() or QApplication([sys.argv[0] if sys.argv else "flatweave"])
    app.setApplicationName("flatweave")
    window = MainWindow()
    if args.size is not None:
        window.resize(*args.size)
    window.confirm_close = not args.quit  # a scripted run never stops to ask
    window.show()
    open_start(window, project, project_path, to_pick)  # a picker opens over the shown window
    if not args.quit:  # offer back what a crashed flatweave autosaved
        if window.recovery_problem:
            window.statusBar().showMessage(window.recovery_problem, 15000)
        QTimer.singleShot(0, window.check_recovery)

    status = {"code": 0}

    def fail(message: str) -> None:
        print(f"flatweave: error: {message}", file=sys.stderr)
        status["code"] = 1
        if args.quit:
            window.close()
            app.quit()

    def finish() -> None:
        if args.screenshot is not None:
            window.view.render()
            window.pattern_view.render()
            app.processEvents()
            if not window.grab().save(str(args.screenshot)):
                fail(f"cannot write {args.screenshot}")
                return
        if args.quit:
            window.close()
            app.quit()

    if args.run or args.screenshot is not None or args.quit:
        waited = {"ms": 0}

        def start_up() -> None:
            ready = window.view.is_ready() and window.pattern_view.is_ready()
            if not ready and waited["ms"] < READY_TIMEOUT_MS:
                waited["ms"] += READY_POLL_MS
                QTimer.singleShot(READY_POLL_MS, start_up)
                return
            window.view.reset_camera()  # now that the window has its size
            if args.run:
                window.run_finished.connect(lambda _outcome: finish())
                window.run_failed.connect(fail)
                if args.quit:
                    QTimer.singleShot(int(args.timeout * 1000),
                                      lambda: fail(f"the solve took longer than {args.timeout:g} s"))
                window.run()
            else:
                finish()

        QTimer.singleShot(0, start_up)

    code = app.exec()
    window.close()  # closes the render windows if the event loop ended otherwise
    return status["code"] or code


if __name__ == "__main__":
    sys.exit(main())
