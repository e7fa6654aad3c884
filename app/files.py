"""Open, save, save as, autosave and recovery for the window.

:func:`flatweave.reading.registry.open_path` decides whether a file is a project or a
surface (the command uses it too); :func:`open_filter` and
:func:`project_filter` build the file dialogs' filters. Work is never lost: a
:class:`flatweave.document.recovery.Session` autosaves the document (every minute when it
changed, and after every solve) on a background thread,
:meth:`Files.check_recovery` offers back what a crashed session left, and saves
keep the last few versions as backups.
"""

from __future__ import annotations

import sys
import traceback
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import replace
from pathlib import Path

from PySide6.QtCore import QObject, Qt, QTimer, Signal
from PySide6.QtGui import QAction
from PySide6.QtWidgets import QFileDialog, QMessageBox

from flatweave.errors import FlatweaveError
from flatweave.reading.examples import example_info, example_path, list_examples
from flatweave.document.project import PROJECT_SUFFIX, UNITS, Project
from flatweave.document.recovery import Orphan, Session, find_orphans, save_with_backups
from flatweave.reading.registry import dialog_filter, open_path, reader_for

from flatweave.app.actions import view_choices
from flatweave.app.facepicker import FacePicker
from flatweave.app.meshpicker import MeshLoopPicker
from flatweave.app.meshdialog import MeshDialog
from flatweave.geometry.meshfit import mesh_surface
from flatweave.reading.meshes import fit_mesh
from flatweave.app.worker import one_line
from flatweave.reading.cadjoin import join_faces

__all__ = ["Files", "open_filter", "project_filter", "AUTOSAVE_MS", "stored_view"]

AUTOSAVE_MS = 60_000  # the document is autosaved this often when it has changed (and after each solve)

def stored_view(project: Project) -> dict:
    """The view choices saved with ``project`` (``Project.view``, kept in the
    file's "display" entry; {} when none are)."""
    return dict(project.view)


def open_filter() -> str:
    """The Open dialog's filter: every registered reader (:mod:`flatweave.reading.registry`)."""
    return dialog_filter() + ";;All files (*)"


def project_filter() -> str:
    """The Save As dialog's filter."""
    return f"flatweave projects (*{PROJECT_SUFFIX})"


def example_units(units) -> str:
    """An example's units if the project knows them, else metres."""
    return units if units in UNITS else "m"


class Files(QObject):
    """The window's files. ``window`` gives the document, ``set_project``,
    ``set_surface``, ``show_error`` and the status bar. ``recovery``: autosave
    to a recovery file (see :mod:`flatweave.document.recovery`)."""

    autosave_failed = Signal(str)  # from the autosave thread

    def __init__(self, window, recovery: bool = True):
        super().__init__(window)
        self.window = window
        self.session: Session | None = None
        self.recovery_box: QMessageBox | None = None
        self.face_picker: FacePicker | MeshLoopPicker | None = None  # open while a face or a mesh's piece is chosen
        self.mesh_dialog: MeshDialog | None = None  # the last question of a mesh's units and fit
        self.recovery_problem: str | None = None
        if recovery:
            try:
                self.session = Session()
            except (FlatweaveError, OSError) as exc:
                self.recovery_problem = f"Autosave is off: {exc}"
        self._autosaver = ThreadPoolExecutor(max_workers=1, thread_name_prefix="flatweave-autosave")
        self._autosaved_revision: int | None = None
        self.last_autosave: Future | None = None
        self.autosave_timer = QTimer(window, interval=AUTOSAVE_MS)
        self.autosave_timer.timeout.connect(self.autosave)
        self.autosave_timer.start()
        self.autosave_failed.connect(lambda m: window.statusBar().showMessage(m, 10000))

    def _status(self, text: str, ms: int) -> None:
        self.window.statusBar().showMessage(text, ms)

    # ------------------------------------------------------------------ open
    def open_file(self, path: str | Path, add: bool = False) -> bool:
        """Open a project (.flatweave) or a surface file; on failure show the error, keep the document.
        Unsaved work is asked about first (:meth:`may_replace`); False if the user keeps it.
        ``add``: the file's pieces join the document instead (Pieces > Add from a file: a face of
        the part, another file), on their own surface, as one undoable edit; nothing is replaced."""
        path = Path(path)
        if not add and not self.may_replace(f"opening {path.name}"):
            return False
        try:
            opened = open_path(path)
            if opened.project is not None:
                if not self._deliver(opened.project, add, path):
                    return False
            elif opened.cad is not None and opened.face is None:
                self.pick_face(opened, add)
                return True
            elif opened.mesh is not None and (opened.surface is None or opened.mesh.advice):
                self.pick_mesh_region(opened, add)
                return True
            else:  # a surface, or a CAD file's only face (its region and units with it)
                if not self._deliver(opened.as_project(), add):
                    return False
                self.ask_mesh(opened)
        except (FlatweaveError, OSError) as exc:
            reader = reader_for(path)
            self.window.show_error(f"Cannot open {'project' if reader and reader.project else 'surface'}: {exc}")
            return False
        self._status(f"{'Added the pieces of' if add else 'Opened'} {path}", 5000)
        return True

    def _deliver(self, project: Project, add: bool, path: str | Path | None = None) -> bool:
        """``project`` (opened from ``path``) made the document, or with ``add`` its pieces added to
        the document's (a new document when there is none); False when that was refused (said)."""
        if add and self.window.document is not None:
            return self.window.add_pieces_from(project)
        self.window.set_project(project, path)
        return True

    def _may_open(self, opened, asked_at: int | None, add: bool) -> bool:
        """Whether a file picked from may be opened now: adding replaces nothing; otherwise unsaved
        work is asked about unless it was when the file was opened (at revision ``asked_at``)."""
        doc = self.window.document
        return add or (doc is not None and doc.revision == asked_at) or self.may_replace(f"opening {opened.path.name}")

    def pick_face(self, opened, add: bool = False) -> FacePicker:
        """Show the face picker (non-modal) for a STEP or IGES file with several
        faces; its OK opens the chosen face (:meth:`open_face`)."""
        if self.face_picker is not None:
            self.face_picker.close()
        doc = self.window.document
        asked_at = None if doc is None else doc.revision  # unsaved work was asked about at this revision
        picker = FacePicker(opened, self.window)
        picker.chosen.connect(lambda index: self.open_face(opened, index, asked_at, add))
        picker.joined.connect(lambda faces: self.open_faces(opened, faces, asked_at, add))
        picker.finished.connect(lambda _result: self._picker_closed(picker))
        self.face_picker = picker
        picker.show()
        self._status(f"{opened.path.name} has {len(opened.cad.faces)} faces: choose one", 10000)
        return picker

    def _picker_closed(self, picker) -> None:
        if self.face_picker is picker:
            self.face_picker = None

    def pick_mesh_region(self, opened, add: bool = False) -> MeshLoopPicker:
        """Show the region picker (non-modal) for a closed mesh (or one with
        handles, or far from developable): the piece's outline is drawn on it,
        and its OK cuts the piece out and opens it (:meth:`open_mesh_region`);
        an open mesh can be opened whole instead."""
        if self.face_picker is not None:
            self.face_picker.close()
        doc = self.window.document
        asked_at = None if doc is None else doc.revision
        picker = MeshLoopPicker(opened, self.window)
        picker.chosen.connect(lambda loop: self.open_mesh_region(opened, loop, asked_at, add))
        picker.seamed.connect(lambda seam: self.open_mesh_seam(opened, seam, asked_at, add))
        picker.whole.connect(lambda: self.open_mesh_whole(opened, asked_at, add))
        picker.finished.connect(lambda _result: self._picker_closed(picker))
        self.face_picker = picker
        picker.show()
        reason = picker.reason.split(":")[0]
        how = ("draw a seam on it (click points from one open end to another, then OK)" if picker.seam
               else "draw the piece on it (click points round it, then OK)")
        self._status(f"{reason}: {how}", 15000)
        return picker

    def open_mesh_whole(self, opened, asked_at: int | None = None, add: bool = False) -> bool:
        """Open an open mesh as one piece (its picker's "Open it whole")."""
        if not self._may_open(opened, asked_at, add) or not self._deliver(opened.as_project(), add):
            return False
        self._status(f"Opened {opened.path} whole", 5000)
        self.ask_mesh(opened)
        return True

    def open_mesh_region(self, opened, loop3d, asked_at: int | None = None, add: bool = False) -> bool:
        """Open the piece of a mesh inside ``loop3d`` ((k, 3) points drawn on it) as a
        new document (:meth:`flatweave.reading.meshes.MeshFile.cut`: the inside of the loop)."""
        return self._open_mesh_piece(opened, lambda: opened.mesh.cut(loop3d), asked_at, add,
                                     f"Cannot cut the piece out of {opened.path.name}",
                                     f"Opened the piece drawn on {opened.path}")

    def open_mesh_seam(self, opened, seam3d, asked_at: int | None = None, add: bool = False) -> bool:
        """Open a tube-shaped mesh along ``seam3d`` ((k, 3) points drawn on it from one
        open end to another) as a new document (:meth:`flatweave.reading.meshes.MeshFile.cut_along`)."""
        return self._open_mesh_piece(opened, lambda: opened.mesh.cut_along(seam3d), asked_at, add,
                                     f"Cannot open {opened.path.name} along the seam",
                                     f"Opened {opened.path} along the seam drawn on it")

    def _open_mesh_piece(self, opened, cut, asked_at: int | None, add: bool, failed: str, done: str) -> bool:
        """The piece ``cut()`` makes of a mesh as a new document, or added to it (``add``; unsaved
        work asked about first, unless at revision ``asked_at``); its error shown after ``failed``."""
        if not self._may_open(opened, asked_at, add):
            return False
        try:
            piece = cut()
            project = replace(opened, surface=piece.surface, region=piece.region).as_project()
        except (FlatweaveError, OSError) as exc:
            self.window.show_error(f"{failed}: {exc}")
            return False
        if not self._deliver(project, add):
            return False
        self._status(f"{done}: {piece.fit.describe()}", 10000)
        self.ask_mesh(opened)
        return True

    def ask_mesh(self, opened) -> MeshDialog | None:
        """For a mesh (a file that carries no units): the project took the unit its size suggests;
        ask (non-modal) whether that is right, and show the fit with a tolerance to refit to. Each
        answer is one edit (:meth:`refit_mesh`)."""
        project = self.window.project
        fit = getattr(project.surface, "fit", None) if project is not None else None
        if opened.units_guess is None or fit is None:
            return None
        dialog = MeshDialog(Path(fit.source).name or project.name, fit, project.units, self.window)
        doc = self.window.document

        def chosen(unit):
            if self.window.document is doc and unit != doc.project.units:
                self.window.edit_display("Units", {"units": unit})

        dialog.chosen.connect(chosen)
        dialog.refit.connect(lambda tolerance: self.refit_mesh(doc, tolerance))
        self.mesh_dialog = dialog
        dialog.show()
        return dialog

    def refit_mesh(self, doc, tolerance: float) -> bool:
        """Refit the document's surface (fitted to a mesh) to ``tolerance`` (model units) as one
        undoable edit: the same mesh and the same flat map, so the region and what is drawn on it
        stay. A tolerance the mesh cannot meet is shown, and nothing changes."""
        if doc is None or self.window.document is not doc:
            return False
        surface = doc.project.surface
        fit = getattr(surface, "fit", None)
        if fit is None:
            self.window.show_error("Fit tolerance: this surface was not fitted to a mesh")
            return False
        try:
            mesh = surface.mesh if surface.mesh is not None else fit_mesh(surface)  # a reopened project reads it
            piece = mesh_surface(mesh.vertices, mesh.triangles, source=fit.source, name=Path(fit.source).name,
                                 repairs=fit.repairs, faces=fit.faces, tolerance=tolerance)
        except (FlatweaveError, OSError) as exc:
            self.window.show_error(f"Fit tolerance: {exc}")
            return False
        doc.refit_surface("Fit tolerance", piece.surface)
        self._status(f"Refitted: {piece.fit.describe()}", 10000)
        return True

    def open_face(self, opened, index: int, asked_at: int | None = None, add: bool = False) -> bool:
        """Open face ``index`` of a CAD file (``opened``, :func:`flatweave.reading.registry.open_path`'s)
        as a new document: its surface and trimmed region; the project's name and
        source say which face of which file (``source`` is ``"path#face=N"``).
        Unsaved work is asked about unless it was when the file was opened
        (``asked_at``, the document's revision then). ``add``: its piece joins the document's."""
        if not self._may_open(opened, asked_at, add):
            return False
        try:
            face = opened.with_face(index)
            project = face.as_project()
        except (FlatweaveError, OSError) as exc:
            self.window.show_error(f"Cannot open face {index} of {opened.path.name}: {exc}")
            return False
        project = replace(project, name=f"{project.name} face {face.face}", source=f"{opened.source}#face={face.face}")
        if not self._deliver(project, add):
            return False
        self._status(f"Opened face {face.face} of {opened.path}", 5000)
        return True

    def open_faces(self, opened, faces, asked_at: int | None = None, add: bool = False) -> bool:
        """Open faces ``faces`` of a CAD file joined into one surface
        (:func:`flatweave.reading.cadjoin.join_faces`: tessellated, welded, fitted as a mesh) as a
        new document; ``source`` is ``"path#faces=2,5,7"``, and the project keeps
        the fitted surface, so it reopens without the CAD file."""
        from PySide6.QtWidgets import QApplication

        if not self._may_open(opened, asked_at, add):
            return False
        listed = ",".join(str(int(i)) for i in faces)
        self._status(f"Joining faces {listed} of {opened.path.name}...", 0)
        QApplication.setOverrideCursor(Qt.CursorShape.WaitCursor)
        try:
            piece = join_faces(opened.cad, faces)
            project = replace(opened, surface=piece.surface, region=piece.region, face=None).as_project()
        except (FlatweaveError, OSError) as exc:
            self.window.show_error(f"Cannot join faces {listed} of {opened.path.name}: {exc}")
            self._status("", 1)
            return False
        finally:
            QApplication.restoreOverrideCursor()
        project = replace(project, name=f"{project.name} faces {listed}", source=f"{opened.source}#faces={listed}")
        if not self._deliver(project, add):
            return False
        self._status(f"Opened faces {listed} of {opened.path} joined: {piece.fit.describe()}", 10000)
        return True

    def open_example(self, name: str) -> bool:
        """Open a bundled example with its recommended spacing and units (asking about unsaved work first)."""
        try:
            info = example_info(name)
        except (FlatweaveError, OSError) as exc:
            self.window.show_error(f"Cannot open example {name}: {exc}")
            return False
        title = info.get("title") or name
        if not self.may_replace(f"opening the example {name}"):
            return False
        try:
            opened = open_path(example_path(name))
        except (FlatweaveError, OSError) as exc:
            self.window.show_error(f"Cannot open example {name}: {exc}")
            return False
        self.window.set_surface(opened.surface, opened.path, spacing=opened.spacing,
                                units=example_units(opened.units))
        self._status(f"Opened the example {title}", 5000)
        return True

    def fill_examples_menu(self, menu) -> None:
        try:
            examples = list_examples()
        except (FlatweaveError, OSError, ValueError):  # a broken install: no menu entries
            examples = []
        for entry in examples:
            name = entry["name"]
            a = QAction(entry.get("title") or name, self.window)
            a.setData(name)
            if entry.get("description"):
                a.setStatusTip(entry["description"])
            a.triggered.connect(lambda checked=False, n=name: self.open_example(n))
            menu.addAction(a)
        if not examples:
            menu.addAction("(no examples found)").setEnabled(False)

    def open_dialog(self, add: bool = False) -> None:
        """Ask for a file and open it (``add``: add its pieces to the document's)."""
        doc = self.window.document
        start = str(doc.path.parent) if doc and doc.path else ""
        title = "Add the pieces of a surface, part or project" if add else "Open project or surface"
        path, _ = QFileDialog.getOpenFileName(self.window, title, start, open_filter())
        if path:
            self.open_file(path, add)

    # ------------------------------------------------------------------ save
    def save(self) -> bool:
        doc = self.window.document
        if doc is None:
            return False
        if doc.path is None or doc.path.suffix.lower() != PROJECT_SUFFIX:
            return self.save_as()
        return self.save_to(doc.path)

    def save_as(self) -> bool:
        doc = self.window.document
        if doc is None:
            return False
        start = str(doc.path.with_suffix(PROJECT_SUFFIX)) if doc.path else f"{doc.project.name}{PROJECT_SUFFIX}"
        path, _ = QFileDialog.getSaveFileName(self.window, "Save project", start, project_filter())
        return bool(path) and self.save_to(path)

    def save_to(self, path: str | Path) -> bool:
        """Save the project to ``path`` (``.flatweave`` added if missing)."""
        doc = self.window.document
        path = Path(path)
        if path.suffix.lower() != PROJECT_SUFFIX:
            path = path.with_name(path.name + PROJECT_SUFFIX)
        try:
            save_with_backups(self.as_saved(doc.project), path)
        except Exception as exc:  # any failure is said, in one line; the document stays unsaved (dirty)
            if not isinstance(exc, FlatweaveError):  # a bug, not a user error: keep its traceback
                traceback.print_exc(file=sys.stderr)
            self.window.show_error(f"Cannot save: {one_line(exc)}")
            return False
        doc.mark_saved(path)
        self.autosave()  # nothing left to recover
        self._status(f"Saved {path}", 5000)
        return True

    def ask_to_save(self, doing: str) -> bool:
        """Ask what to do with the document's unsaved work before ``doing``
        ("closing", "opening cone"): Save (True only if it saved; a failed or
        cancelled save is False), Discard (True) or Cancel (False)."""
        buttons = QMessageBox.StandardButton
        answer = QMessageBox.question(
            self.window, "flatweave", f"Save the changes to {self.window.document_name} before {doing}?",
            buttons.Save | buttons.Discard | buttons.Cancel, buttons.Save)
        if answer == buttons.Save:
            return self.save()
        return answer == buttons.Discard

    def as_saved(self, project: Project) -> Project:
        """``project`` as a file keeps it: with the window's view choices (strain
        or shear, the springs shown, ...). They are view state, not edits: no
        undo step, no "*"; they are written whenever the project is."""
        return replace(project, view=tuple(sorted(view_choices(self.window.actions).items())))

    def confirm_close(self) -> bool:
        """Ask what to do with unsaved work: Save (and close if it saved), Discard, or Cancel."""
        return self.ask_to_save("closing")

    def may_replace(self, doing: str) -> bool:
        """May the document be replaced (by ``doing``: an open, an example, a
        recovery)? Always when nothing would be lost or the window does not ask
        (``window.confirm_close``, the launcher's and not the tests' default);
        otherwise the answer to :meth:`ask_to_save`."""
        w = self.window
        if not w.confirm_close or w.document is None or not w.document.unsaved_work:
            return True
        return self.ask_to_save(doing)

    # ------------------------------------------------------------------ autosave and recovery
    def autosave(self) -> Future | None:
        """Write the document to this session's recovery file if it changed
        since the last autosave (or clear the file when nothing is unsaved).
        The write runs on the autosave thread; returns its Future (None if
        there was nothing to do)."""
        doc = self.window.document
        if self.session is None or doc is None or doc.revision == self._autosaved_revision:
            return None
        self._autosaved_revision = doc.revision
        if doc.unsaved_work:
            self.last_autosave = self._autosaver.submit(self._write_recovery, self.as_saved(doc.project), doc.path)
        else:
            self.last_autosave = self._autosaver.submit(self.session.clear)
        return self.last_autosave

    def _write_recovery(self, project: Project, path) -> None:  # on the autosave thread
        try:
            self.session.write(project, path)
        except FlatweaveError as exc:
            self._autosaved_revision = None  # try again at the next tick
            self.autosave_failed.emit(f"Autosave failed: {exc}")

    def check_recovery(self, folder: str | Path | None = None) -> Orphan | None:
        """Offer back the newest document a crashed flatweave left (a
        non-blocking question: Recover, Discard, or Later). Returns what is offered."""
        if self.recovery_box is not None:
            return None
        if folder is None and self.session is None:
            return None
        orphans = find_orphans(self.session.folder if folder is None else folder)
        if not orphans:
            return None
        offered, rest = orphans[0], orphans[1:]
        for other in rest:  # offered one at a time: the others at the next check
            other.release()
        box = QMessageBox(QMessageBox.Icon.Question, "flatweave: recover unsaved work",
                          f"flatweave did not close normally. Recover the work it autosaved?\n\n"
                          f"{offered.describe()}", QMessageBox.StandardButton.NoButton, self.window)
        recover = box.addButton("Recover", QMessageBox.ButtonRole.AcceptRole)
        discard = box.addButton("Discard", QMessageBox.ButtonRole.DestructiveRole)
        box.addButton("Later", QMessageBox.ButtonRole.RejectRole)
        box.setDefaultButton(recover)
        box.setWindowModality(Qt.WindowModality.NonModal)

        def answered(_result):  # deleted at its end, not on close: recover may ask a (modal) question first
            clicked = box.clickedButton()
            self.recovery_box = None
            if clicked is recover:
                self.recover(offered)
            elif clicked is discard:
                offered.discard()
                self._status("Discarded the autosaved work.", 5000)
            else:
                offered.release()
            if rest and clicked in (recover, discard):
                QTimer.singleShot(0, lambda: self.check_recovery(folder))
            box.deleteLater()

        box.finished.connect(answered)
        self.recovery_box = box
        box.show()
        return offered

    def recover(self, orphan: Orphan) -> bool:
        """Open ``orphan``'s autosave as the document (unsaved; Save writes it
        where it was saved before), then delete the recovery file once this
        session's own autosave holds the work. Unsaved work in the open
        document is asked about first; kept, the offer stays for later (False)."""
        if not self.may_replace(f"recovering the autosaved {orphan.name}"):
            orphan.release()
            return False
        try:
            project = orphan.load()
        except FlatweaveError as exc:
            orphan.release()
            self.window.show_error(f"Cannot recover {orphan.path}: {exc}")
            return False
        self.window.set_project(project, orphan.document_path, saved=False)
        pending = self.autosave()
        if pending is not None:
            pending.result()
        orphan.discard()
        self._status(f"Recovered {orphan.describe()}; save it to keep it.", 10000)
        return True

    # ------------------------------------------------------------------ lifetime
    def stop_autosaving(self) -> None:
        self.autosave_timer.stop()

    def close(self) -> None:
        """Close the face picker, wait for the last autosave and end the session normally (nothing to recover)."""
        if self.face_picker is not None:
            self.face_picker.close()
            self.face_picker = None
        self._autosaver.shutdown(wait=True)
        if self.session is not None:
            self.session.close()
            self.session = None
