"""A format registered with one call is offered by the window: the Open dialog
lists a toy reader's files and opens one, the Export dialog lists a toy exporter."""

from __future__ import annotations

from pathlib import Path

import pytest
from PySide6.QtWidgets import QFileDialog

from flatweave.reading.examples import load_example
from flatweave.export.registry import ExportOption, register_exporter, unregister_exporter
from flatweave.reading.opened import Opened
from flatweave.reading.registry import register_reader, unregister_reader


@pytest.fixture
def toy_formats():
    register_exporter(".txt", lambda result, options, sheet: options.get("tag").encode() + b"\n", "toy outline",
                      needs_sheet=True, options=(ExportOption("tag", "text", "toy", "the toy's one word", "Tag"),))
    register_reader("toy", ".toy", lambda path: Opened(surface=load_example("dome"), units="cm"), "toy surface")
    yield
    unregister_exporter(".txt")
    unregister_reader("toy")


def test_the_open_dialog_offers_and_opens_a_registered_reader(toy_formats, make_window, tmp_path, monkeypatch):
    win = make_window()
    toy = tmp_path / "part.toy"
    toy.write_text("anything")
    asked = {}

    def fake_open(parent, caption, start, filters):
        asked["filters"] = filters
        return str(toy), filters.split(";;")[0]

    monkeypatch.setattr(QFileDialog, "getOpenFileName", staticmethod(fake_open))
    win.actions["open"].trigger()
    assert "*.toy" in asked["filters"].split(";;")[0] and "toy surface (*.toy)" in asked["filters"].split(";;")
    assert win.project.source == str(toy) and win.project.name == "part"
    assert win.surface.bbox_diagonal() == pytest.approx(load_example("dome").bbox_diagonal())


def test_the_export_dialog_offers_a_registered_exporter(toy_formats, qtbot, monkeypatch, tmp_path):
    from flatweave.app.exporting import ExportDialog

    dialog = ExportDialog(tmp_path / "piece.dxf", "m", "piece")
    qtbot.addWidget(dialog)
    assert dialog.format.findData(".txt") >= 0 and "txt" in dialog.every_format.text()
    asked = {}

    def fake_save(parent, caption, start, filters):
        asked["filters"] = filters
        return str(tmp_path / "piece.txt"), ""

    monkeypatch.setattr(QFileDialog, "getSaveFileName", staticmethod(fake_save))
    dialog._browse()
    assert "toy outline (*.txt)" in asked["filters"].split(";;")
    assert dialog.format.currentData() == ".txt"
    assert [p.suffix for p in dialog.paths()] == [".txt"]
    assert Path(dialog.path.text()).name == "piece.txt"
    # its declared option is a row of the dialog, and what is typed there reaches the writer's options
    assert dialog.fields["tag"].text() == "toy" and dialog.fields["tag"].toolTip() == "the toy's one word"
    dialog.fields["tag"].setText("hello")
    assert dialog.options().get("tag") == "hello"
