"""The window meets the hostile corpus through File > Open (issue 45, item 6): every bad surface
file (tests/data/bad), every hostile input (tests/data/hostile), a pipe and a file name too long
for the system are refused with one line shown, and the document (a solved, edited, unsaved
project) is left exactly as it was: nothing replaced, nothing lost."""

from __future__ import annotations

import os
from pathlib import Path


from flatweave.document.project import project_to_dict

DATA = Path(__file__).parent / "data"
CORPUS = sorted([*(DATA / "bad").iterdir(), *(DATA / "hostile").glob("*.json")])


def test_every_hostile_file_opened_in_the_window_leaves_the_document_as_it_was(make_window, qtbot, tmp_path):
    win = make_window(example="octant")
    done = []
    win.run_finished.connect(done.append)
    win.run()
    qtbot.waitUntil(lambda: bool(done), timeout=60000)
    win.document.edit_settings("Spacing", spacing=0.1)  # unsaved work: must survive every refusal
    before, revision = project_to_dict(win.project), win.document.revision
    shown = []
    win.show_error = shown.append
    paths = list(CORPUS)
    if hasattr(os, "mkfifo"):
        os.mkfifo(tmp_path / "pipe.json")
        paths.append(tmp_path / "pipe.json")
    paths.append(tmp_path / ("a" * 300 + ".json"))
    assert len(paths) > 60
    for path in paths:
        shown.clear()
        opened = win.open_file(path)
        assert not opened, path
        assert len(shown) == 1 and "\n" not in shown[0] and shown[0], (path, shown)
        assert win.document.revision == revision and win.files.face_picker is None, path
    assert project_to_dict(win.project) == before and win.document.unsaved_work
