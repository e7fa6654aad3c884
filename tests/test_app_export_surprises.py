"""File > Export asks before an export that could surprise (here a PDF of more than
50 pages: the octant of the unit sphere in metres on A4), writes nothing on No, and
writes on Yes the PDF it described (read back with pypdf)."""

from __future__ import annotations

import re

import pytest
from PySide6.QtWidgets import QMessageBox

from flatweave.reading.examples import example_path, load_example
from flatweave.export.registry import MAX_QUIET_PAGES
from flatweave.document.project import new_project


def solved_window(make_window, qtbot):
    win = make_window(new_project(load_example("octant"), "octant", str(example_path("octant")), 0.1))
    with qtbot.waitSignal(win.run_finished, timeout=60000):
        win.run()
    return win


def open_export(win, qtbot, path, units):
    win.actions["export"].trigger()
    dialog = win.export_box
    qtbot.waitUntil(dialog.isVisible)
    dialog.path.setText(str(path))
    dialog.path.textEdited.emit(dialog.path.text())
    dialog.fields["units"].setCurrentIndex(dialog.fields["units"].findData(units))
    dialog.fields["paper"].setCurrentIndex(dialog.fields["paper"].findData("a4"))
    return dialog


@pytest.mark.slow
def test_export_asks_before_a_long_pdf_and_writes_nothing_on_no(make_window, qtbot, tmp_path, monkeypatch):
    from pypdf import PdfReader

    win = solved_window(make_window, qtbot)
    pdf = tmp_path / "octant.pdf"
    asked, answer = [], [QMessageBox.StandardButton.No]

    def question(parent, title, text, buttons, default):
        asked.append(text)
        return answer[0]

    monkeypatch.setattr(QMessageBox, "question", staticmethod(question))
    dialog = open_export(win, qtbot, pdf, "m")
    dialog.export_button.click()
    (text,) = asked
    assert "units m" in text and text.endswith("Write it?")
    pages = int(re.search(r"([\d,]+) pages", text).group(1).replace(",", ""))
    assert pages > MAX_QUIET_PAGES
    # No: nothing started, nothing written, the dialog still open to change the units
    qtbot.wait(200)
    assert win.export_thread is None and not pdf.exists() and dialog.isVisible()
    # Yes: the PDF written has the pages the question named
    answer[0] = QMessageBox.StandardButton.Yes
    with qtbot.waitSignal(win.export_finished, timeout=60000):
        dialog.export_button.click()
    assert len(asked) == 2 and len(PdfReader(pdf).pages) == pages
    qtbot.waitUntil(lambda: win.export_thread is None, timeout=5000)


def test_export_of_a_short_pdf_does_not_ask(make_window, qtbot, tmp_path, monkeypatch):
    from pypdf import PdfReader

    win = solved_window(make_window, qtbot)
    asked = []
    monkeypatch.setattr(QMessageBox, "question", staticmethod(lambda *a: asked.append(a)))
    dialog = open_export(win, qtbot, tmp_path / "octant.pdf", "cm")
    with qtbot.waitSignal(win.export_finished, timeout=60000):
        dialog.export_button.click()
    assert asked == [] and len(PdfReader(tmp_path / "octant.pdf").pages) <= MAX_QUIET_PAGES
    qtbot.waitUntil(lambda: win.export_thread is None, timeout=5000)
