"""``flatweave``: the desktop app's command.

    flatweave [SURFACE.json] [--screenshot OUT.png] [--quit]

With no surface it opens the sphere-octant example. ``--screenshot`` saves an
image of the window once the 3D view has rendered; ``--quit`` exits right
after start-up (and after the screenshot), which makes a smoke test.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

DEFAULT_EXAMPLE = "octant"
READY_POLL_MS = 50
READY_TIMEOUT_MS = 10000


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="flatweave",
        description="Flat cutting patterns for fabric covering NURBS surfaces (desktop app).")
    parser.add_argument("surface", nargs="?", type=Path,
                        help="surface file (geomdl JSON); default: the sphere-octant example")
    parser.add_argument("--screenshot", type=Path, metavar="OUT.png",
                        help="save an image of the window once it has rendered")
    parser.add_argument("--quit", action="store_true",
                        help="quit right after start-up (after the screenshot, if any)")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)

    # Load the surface before any Qt work: a bad file is a one-line error, status 2.
    from core.errors import FlatweaveError
    from core.examples import example_path
    from core.surface_io import load_surface

    try:
        path = args.surface if args.surface is not None else Path(example_path(DEFAULT_EXAMPLE))
        surface = load_surface(path)
    except (FlatweaveError, OSError) as exc:
        print(f"flatweave: error: {exc}", file=sys.stderr)
        return 2

    from PySide6.QtCore import QTimer
    from PySide6.QtWidgets import QApplication

    from app.mainwindow import MainWindow

    app = QApplication.instance() or QApplication([sys.argv[0] if sys.argv else "flatweave"])
    app.setApplicationName("flatweave")
    window = MainWindow()
    window.set_surface(surface, path)
    window.show()

    status = {"code": 0}
    if args.screenshot is not None or args.quit:
        waited = {"ms": 0}

        def finish_start_up() -> None:
            if not window.view.is_ready() and waited["ms"] < READY_TIMEOUT_MS:
                waited["ms"] += READY_POLL_MS
                QTimer.singleShot(READY_POLL_MS, finish_start_up)
                return
            if args.screenshot is not None:
                window.view.render()
                app.processEvents()
                if not window.grab().save(str(args.screenshot)):
                    print(f"flatweave: error: cannot write {args.screenshot}", file=sys.stderr)
                    status["code"] = 1
            if args.quit:
                window.close()
                app.quit()

        QTimer.singleShot(0, finish_start_up)

    code = app.exec()
    window.close()  # closes the render window if the event loop ended otherwise
    return status["code"] or code


if __name__ == "__main__":
    sys.exit(main())
