"""File > Export: the dialog (file, format, and a row for each option the formats declare),
the thread that writes the files with :mod:`flatweave.export.registry`, and the window's
export commands (:class:`Exports`).

The format follows the file name's suffix (and choosing a format changes the
suffix); "every format" writes one file per format next to each other. An
export that would surprise (:func:`flatweave.export.registry.surprises`: a PDF of hundreds of
pages, a piece metres across) is asked about first; No writes nothing and
leaves the dialog open. The files are written off the GUI thread (a tiled PDF
takes about a second), each atomically by ``flatweave.export.registry``.
"""

from __future__ import annotations

import sys
import traceback
from pathlib import Path

from PySide6.QtCore import Qt, QThread, Signal
from PySide6.QtWidgets import (QCheckBox, QComboBox, QDialog, QDialogButtonBox, QDoubleSpinBox, QFileDialog,
                               QFormLayout, QHBoxLayout, QLabel, QLineEdit, QMessageBox, QPushButton, QVBoxLayout,
                               QWidget)

from flatweave.document.cutfiles import export_pieces, file_stem
from flatweave.document.plybook import write_ply_book
from flatweave.document.sewing import piece_sheet, sewing_of
from flatweave.errors import FlatweaveError
from flatweave.export.registry import (FORMATS, ExportOption, ExportOptions, dialog_filter, export_all,
                                       export_options, option_formats, surprises)
from flatweave.method.result import FlattenResult

from flatweave.app.worker import one_line

__all__ = ["ExportDialog", "ExportThread", "Exports", "export_paths", "export_filter"]


def export_filter() -> str:
    """The export file dialog's filter: one entry per registered format (:mod:`flatweave.export.registry`)."""
    return dialog_filter()


def export_paths(path: str | Path, every_format: bool) -> list[Path]:
    """The files an export writes: ``path``, or with ``every_format`` one file per
    format with ``path``'s folder and stem."""
    path = Path(path)
    if not every_format:
        return [path]
    stem = path.with_suffix("") if path.suffix.lower() in FORMATS else path
    return [stem.with_name(stem.name + suffix) for suffix in FORMATS]


class ExportThread(QThread):
    """Writes ``paths`` for ``result``; ``succeeded(list of Path)`` or ``failed(str)``."""

    succeeded = Signal(object)
    failed = Signal(str)

    def __init__(self, result: FlattenResult | None, paths: list[Path], options: ExportOptions, parent=None,
                 job=None):
        super().__init__(parent)
        self.result, self.paths, self.options = result, list(paths), options
        self.job = job  # job() -> the paths written, in place of export_all (the ply book, all pieces)

    def run(self) -> None:
        try:
            written = self.job() if self.job is not None else export_all(self.result, self.paths, self.options)
        except Exception as exc:  # every failure reaches the window as one line
            if not isinstance(exc, FlatweaveError):
                traceback.print_exc(file=sys.stderr)
            self.failed.emit(one_line(exc))
            return
        self.succeeded.emit(written)


class ExportDialog(QDialog):
    """Where and how to export. ``paths()`` and ``options()`` once accepted.

    ``check(paths, options)``, if given, lists the export's surprises
    (:class:`flatweave.export.registry.Surprise`); Export asks about them and accepts only on Yes.
    """

    def __init__(self, path: Path, units: str, name: str, options: ExportOptions | None = None,
                 every_format: bool = False, stale: bool = False, parent=None, check=None):
        options = options if options is not None else ExportOptions()
        super().__init__(parent)
        self.check = check
        self.setWindowTitle("Export pattern")
        layout = QVBoxLayout(self)
        form = QFormLayout()
        self.path = QLineEdit(str(path))
        browse = QPushButton("Browse...")
        browse.clicked.connect(self._browse)
        row = QHBoxLayout()
        row.addWidget(self.path, 1)
        row.addWidget(browse)
        holder = QWidget()
        holder.setLayout(row)
        row.setContentsMargins(0, 0, 0, 0)
        form.addRow("File", holder)
        self.format = QComboBox()
        for suffix, text in FORMATS.items():
            self.format.addItem(f"{suffix[1:].upper()}: {text}", suffix)
        form.addRow("Format", self.format)
        self.every_format = QCheckBox("every format (" + ", ".join(s[1:] for s in FORMATS) + ")")
        self.every_format.setChecked(every_format)
        form.addRow("", self.every_format)
        # one row per option the registered formats declare (flatweave.export.registry.export_options)
        values = {**{o.name: options.get(o.name) for o in export_options()}, "units": units, "name": name}
        self.fields = {o.name: self._field(o, values[o.name]) for o in export_options()}
        for o in export_options():
            formats = option_formats(o.name)
            only = formats[0][1:].upper() if len(formats) == 1 else ""
            label = f"{o.label} ({only})" if only and only not in o.label.upper() else o.label
            form.addRow(label, self.fields[o.name])
        layout.addLayout(form)
        if stale:
            note = QLabel("The pattern was made with earlier settings; Run to update it first.")
            note.setStyleSheet("color: #b36b00")
            layout.addWidget(note)
        self.error = QLabel("")
        self.error.setStyleSheet("color: #c00000")
        layout.addWidget(self.error)
        buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Cancel)
        self.export_button = buttons.addButton("Export", QDialogButtonBox.ButtonRole.AcceptRole)
        buttons.accepted.connect(self._accept)
        buttons.rejected.connect(self.reject)
        layout.addWidget(buttons)
        self.path.textEdited.connect(self._path_edited)
        self.format.activated.connect(self._format_chosen)
        self._path_edited(self.path.text())
        self.resize(560, self.sizeHint().height())

    @staticmethod
    def _field(option: ExportOption, value):
        """The widget of one declared option, showing ``value``."""
        if option.kind == "number":
            w = QDoubleSpinBox()
            w.setRange(option.minimum, min(option.maximum, 1e6))
            w.setDecimals(1)
            if option.unit:
                w.setSuffix(f" {option.unit}")
            w.setValue(float(value))
        elif option.kind == "choice":
            w = QComboBox()
            for key, text in option.choices.items():
                w.addItem(text, key)
            w.setCurrentIndex(max(0, w.findData(value)))
        else:
            w = QLineEdit(str(value))
        w.setToolTip(option.help)
        return w

    def value(self, name: str):
        """The value option ``name``'s row shows."""
        w = self.fields[name]
        if isinstance(w, QDoubleSpinBox):
            return float(w.value())
        if isinstance(w, QComboBox):
            return w.currentData()
        return w.text().strip()

    # ------------------------------------------------------------------ format <-> suffix
    def _path_edited(self, text: str) -> None:
        idx = self.format.findData(Path(text).suffix.lower())
        if idx >= 0:
            self.format.setCurrentIndex(idx)

    def _format_chosen(self, _index: int) -> None:
        p = Path(self.path.text())
        if p.name:
            self.path.setText(str(p.with_suffix(self.format.currentData())))

    def _browse(self) -> None:
        path, _ = QFileDialog.getSaveFileName(self, "Export pattern", self.path.text(), export_filter())
        if path:
            self.path.setText(path)
            self._path_edited(path)

    # ------------------------------------------------------------------ results
    def paths(self) -> list[Path]:
        p = Path(self.path.text().strip())
        if not self.every_format.isChecked() and p.suffix.lower() not in FORMATS:
            p = p.with_name(p.name + self.format.currentData())
        return export_paths(p, self.every_format.isChecked())

    def options(self) -> ExportOptions:
        values = {name: self.value(name) for name in self.fields}
        if "name" in values:
            values["name"] = values["name"] or "piece"
        return ExportOptions.from_values(values)

    def _accept(self) -> None:
        if not self.path.text().strip():
            self.error.setText("Choose a file to export to.")
            return
        try:
            options = self.options()
            found = self.check(self.paths(), options) if self.check is not None else []
        except FlatweaveError as exc:
            self.error.setText(str(exc))
            return
        if found and not self._confirm(found, options):
            return
        self.accept()

    def _confirm(self, found, options: ExportOptions) -> bool:
        """Ask whether to write an export despite its surprises; True on Yes."""
        several = len(self.paths()) > 1
        said = "\n".join((s.line() if several else s.text) + "." for s in found)
        text = (f"{said}\n\nIf the model is not in {options.units}, choose its Model units. "
                f"Write {'them' if several else 'it'}?")
        buttons = QMessageBox.StandardButton
        answer = QMessageBox.question(self, "Export pattern", text, buttons.Yes | buttons.No, buttons.No)
        return answer == buttons.Yes


class Exports:
    """The window's File > Export: one export thread at a time. ``window``
    gives the project and document, the status bar, the progress label,
    ``show_error``, ``update_actions`` and the ``export_finished`` /
    ``export_failed`` signals."""

    def __init__(self, window):
        self.window = window
        self.export_thread: ExportThread | None = None
        self.export_box: ExportDialog | None = None
        self.last_export: list[Path] = []
        self.export_options = ExportOptions()  # the last choices (units come from the project)
        self.left_out: list[str] = []  # the pieces an export of all pieces left out (not solved)
        self._every_format = False

    @property
    def busy(self) -> bool:
        return self.export_thread is not None

    def _start_path(self) -> Path:
        if self.last_export:
            return self.last_export[0]
        doc = self.window.document
        folder = doc.path.parent if doc.path is not None else Path.cwd()
        return folder / f"{self.window.surface_name or 'pattern'}.dxf"

    def export_dialog(self) -> None:
        """Ask where and how to export the document's pattern, then export it."""
        project = self.window.project
        if project is None or project.result is None:
            return
        dialog = ExportDialog(self._start_path(), project.units, project.name, self.export_options,
                              self._every_format, stale=not project.result_is_current, parent=self.window,
                              check=lambda paths, options: surprises(project.result, paths, options))
        dialog.setAttribute(Qt.WidgetAttribute.WA_DeleteOnClose)
        self.export_box = dialog

        def accepted():
            self._every_format = dialog.every_format.isChecked()
            self.export_to(dialog.paths(), dialog.options())
        dialog.accepted.connect(accepted)
        dialog.open()

    def export_to(self, paths, options: ExportOptions) -> bool:
        """Write the document's result to ``paths`` (formats from their suffixes) in a
        background thread; ``export_finished`` or ``export_failed`` follows."""
        project = self.window.project
        if project is None or project.result is None or self.export_thread is not None:
            return False
        self.export_options = options
        paths = [Path(p) for p in paths]
        job = None
        if sewing_of(project, project.piece_index) is not None and project.result_is_current:
            # a panel: its seams' notches and own allowances, as its cut files have them
            def job():
                sheet = piece_sheet(project, project.piece_name, options.seam_allowance_mm, name=options.name)
                return export_all(project.result, paths, options, sheet)
        return self._start(ExportThread(project.result, paths, options, job=job), paths)

    # ------------------------------------------------------------------ every piece at once
    def ask_book_path(self, start: Path) -> str:
        """The ply book's file, asked (tests replace this); "" when cancelled."""
        path, _ = QFileDialog.getSaveFileName(self.window, "Export ply book", str(start), "PDF (*.pdf)")
        return path

    def ask_folder(self, start: Path) -> str:
        """The folder of the pieces' cut files, asked (tests replace this); "" when cancelled."""
        return QFileDialog.getExistingDirectory(self.window, "Export all pieces into", str(start))

    def _folder(self) -> Path:
        doc = self.window.document
        return doc.path.parent if doc is not None and doc.path is not None else Path.cwd()

    def export_book_dialog(self) -> None:
        """Ask where to write the project's ply book, then write it."""
        project = self.window.project
        if project is None:
            return
        path = self.ask_book_path(self._folder() / f"{file_stem(project.name)}-ply-book.pdf")
        if path:
            self.export_book_to(path if Path(path).suffix else f"{path}.pdf")

    def export_book_to(self, path) -> bool:
        """Write the project's ply book to ``path`` in a background thread (patterns drawn net:
        no seam allowance); ``export_finished`` or ``export_failed`` follows."""
        project, options = self.window.project, self.export_options
        if project is None or self.export_thread is not None:
            return False
        job = lambda: [write_ply_book(project, path, options.paper)]  # noqa: E731
        return self._start(ExportThread(None, [Path(path)], options, job=job), [path])

    def export_pieces_dialog(self) -> None:
        """Ask a folder, then write every solved piece's cut files into it."""
        if self.window.project is None:
            return
        folder = self.ask_folder(self._folder())
        if folder:
            self.export_pieces_to(folder)

    def export_pieces_to(self, folder, options: ExportOptions | None = None) -> bool:
        """Write every solved piece's cut files into ``folder`` (one DXF with a block per piece, an SVG
        and a tiled PDF per piece; :func:`flatweave.document.cutfiles.export_pieces`) with the last
        export's options, in a background thread."""
        project = self.window.project
        if project is None or self.export_thread is not None:
            return False
        options = options or self.export_options
        self.left_out = []

        def job():
            paths, self.left_out = export_pieces(project, folder, options=options)
            return paths
        return self._start(ExportThread(None, [Path(folder)], options, job=job), [folder])

    def _start(self, t: ExportThread, paths) -> bool:
        t.succeeded.connect(self._succeeded)
        t.failed.connect(self._failed)
        t.finished.connect(self._thread_finished)
        self.export_thread = t
        self.window.statusBar().showMessage(f"Exporting {', '.join(Path(p).name for p in paths)}...")
        self.window.update_actions()
        t.start()
        return True

    def _succeeded(self, written) -> None:
        self.last_export = list(written)
        folder = written[0].parent if written else Path(".")
        names = ", ".join(p.name for p in written)
        text = f"Exported {names} to {folder}"
        if self.left_out:
            text += f"; no cut files for {len(self.left_out)} piece(s) not solved: {', '.join(self.left_out[:4])}"
            self.left_out = []
        self.window.statusBar().showMessage(text, 15000)
        self.window.progress.setText(text)
        self.window.export_finished.emit(list(written))

    def _failed(self, message: str) -> None:
        self.window.show_error(f"Export failed: {message}")
        self.window.export_failed.emit(message)

    def _thread_finished(self) -> None:
        t, self.export_thread = self.export_thread, None
        if t is not None:
            t.wait()
            t.deleteLater()
        self.window.update_actions()

    def close(self) -> None:
        if self.export_thread is not None:
            self.export_thread.wait()  # atomic writes: a few seconds at most
