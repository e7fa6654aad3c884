"""The engine (flatweave without flatweave.app) is headless: it must never import the GUI stack.

Each check runs in a fresh interpreter whose import system refuses the GUI
packages (a meta-path finder first in line raises ImportError for them and
records who asked), so neither this test process's own imports nor an
optional ``try: import pyvista`` inside the engine can hide a violation.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

BLOCKED = ("PySide6", "shiboken6", "PyQt5", "PyQt6", "qtpy", "pyvista", "pyvistaqt",
           "vtk", "vtkmodules", "superqt")
WINDOW = "flatweave.app"

# Installs the blocker; afterwards ATTEMPTS lists (importing module, blocked name).
BLOCKER = textwrap.dedent(f"""
    import importlib.abc
    import sys

    BLOCKED = {BLOCKED!r}
    WINDOW = {WINDOW!r}
    ATTEMPTS = []

    def _importer():
        f = sys._getframe(2)
        while f is not None and (f.f_code.co_filename.startswith("<frozen")
                                 or "importlib" in f.f_code.co_filename):
            f = f.f_back
        return "?" if f is None else f.f_globals.get("__name__", "?")

    class _Blocker(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in BLOCKED or name == WINDOW or name.startswith(WINDOW + "."):
                ATTEMPTS.append((_importer(), name))
                raise ImportError(f"blocked by test_layering: {{name}}")
            return None

    sys.meta_path.insert(0, _Blocker())
""")

IMPORT_ALL = BLOCKER + textwrap.dedent("""
    import importlib
    import pkgutil

    import flatweave

    def engine(name):
        return name.split(".")[0] == "flatweave" and not name.startswith(WINDOW)

    names = ["flatweave"]
    for name in dir(flatweave):  # the public API loads its names on first use
        getattr(flatweave, name)
    for info in pkgutil.walk_packages(flatweave.__path__, "flatweave.", onerror=lambda n: None):
        if info.name == "flatweave.__main__" or info.name.startswith(WINDOW):
            continue  # running __main__ starts the CLI; test_python_m_flatweave covers it
        importlib.import_module(info.name)
        names.append(info.name)

    by_core = [(who, name) for who, name in ATTEMPTS if engine(who)]
    others = [(who, name) for who, name in ATTEMPTS if not engine(who)]
    leaked = sorted(m for m in sys.modules if m.split(".")[0] in BLOCKED or m.startswith(WINDOW))
    print("IMPORTED", " ".join(names))
    print("OTHER_ATTEMPTS", others)
    if by_core or leaked:
        print("VIOLATION", by_core, leaked)
        sys.exit(1)
""")

RUN_M_CORE = BLOCKER + textwrap.dedent("""
    import runpy

    sys.argv = ["python -m flatweave", "--help"]
    try:
        runpy.run_module("flatweave", run_name="__main__", alter_sys=True)
    except SystemExit as exc:
        code = exc.code
    else:
        code = 0
    by_core = [(who, name) for who, name in ATTEMPTS if who.split(".")[0] == "flatweave" and not who.startswith(WINDOW)]
    if by_core:
        print("VIOLATION", by_core)
        sys.exit(1)
    sys.exit(code)
""")


def run_python(script: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", script], cwd=REPO, capture_output=True,
                          text=True, timeout=120)


def test_blocker_blocks():
    """The harness itself works: a blocked import fails and is recorded."""
    proc = run_python(BLOCKER + "try:\n    import pyvista\nexcept ImportError:\n"
                      "    pass\nassert ATTEMPTS and ATTEMPTS[0][1] == 'pyvista', ATTEMPTS\n"
                      "assert 'pyvista' not in sys.modules\n")
    assert proc.returncode == 0, proc.stderr


@pytest.mark.slow
def test_every_engine_module_imports_without_gui_packages():
    proc = run_python(IMPORT_ALL)
    assert proc.returncode == 0, f"{proc.stdout}\n{proc.stderr}"
    imported = proc.stdout.split("IMPORTED", 1)[1].splitlines()[0].split()
    # the walk really happened: the modules every later stage depends on
    for module in ("flatweave", "flatweave.errors", "flatweave.geometry.nurbs", "flatweave.method.pipeline",
                   "flatweave.reading.registry", "flatweave.export.pdf", "flatweave.document.project"):
        assert module in imported
    assert len(imported) >= len(list((REPO / "core").rglob("*.py"))) - 1  # all but __main__


def test_python_m_flatweave_help_without_gui_packages():
    proc = run_python(RUN_M_CORE)
    assert proc.returncode == 0, f"{proc.stdout}\n{proc.stderr}"
    assert "usage" in proc.stdout.lower()
    assert "Traceback" not in proc.stderr
