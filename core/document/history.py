"""The open document: the current :class:`~flatweave.document.project.Project`, its undo
history and the listeners that show it. No Qt: the GUI subscribes, the tests
and a soak test drive it directly.

Every change goes through :meth:`Document.apply` (an edit: one undo step),
:meth:`Document.undo` / :meth:`Document.redo`, :meth:`Document.attach_result`
(a finished solve) or :meth:`Document.reset` (a new or opened document).
Projects are immutable, so an :class:`Edit` is just the project before and
after; undo and redo swap them back and never re-solve.

A finished solve belongs to the edit it answers: when the run started from
the project an edit produced, and that edit is still the latest, the result is
folded into it (undo goes back to the previous result, redo brings this one
back). A solve with no edit to answer (the Run button) is an edit of its own.

The edits a designer makes to darts and yarn constraints have methods of their
own (:meth:`Document.add_dart`, :meth:`~Document.replace_dart`,
:meth:`~Document.remove_dart`, :meth:`~Document.rename_dart`,
:meth:`~Document.set_dart_visible`, :meth:`~Document.add_yarn`, ...), so the
GUI's tools, the tests and a soak test make them the same way. Renaming and
hiding a dart change only labels: the result stays current and no solve
answers them. So do the pieces' (:meth:`Document.add_piece`,
:meth:`~Document.duplicate_piece`, ...); choosing which piece is active
(:meth:`Document.select_piece`) is a change ("select") but not an undo step.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

from flatweave.errors import SettingsError
from flatweave.method.result import FlattenResult, with_shear_angles
from flatweave.document import pieces, sewing
from flatweave.document.project import Project, labels_equal, settings_equal

__all__ = ["Document", "Edit", "Change", "ASPECTS", "unique_name"]

ASPECTS = ("surface", "settings", "labels", "display", "result", "name", "pieces", "seams", "plan")
"""What a change can touch: listeners get the set of aspects that differ.
"labels" are what never changes a solve: the darts' names and visibility and
a curve dart's drawn points (see :func:`flatweave.document.project.labels_equal`).
"pieces" are the list of pieces (flatweave.document.pieces): which is active, their
names, order, quantities and sequence, the pieces not active, and the materials table.
"seams" are the shapes split by seams (flatweave.document.sewing): a seam drawn, moved,
renamed, its options. "plan" is the cut plan's settings (flatweave.document.cutsettings): roll widths,
gap, splices placed by hand, mirror pairs."""


@dataclass(frozen=True)
class Edit:
    """One undo step: the project before and after, and what the user called it."""

    label: str
    before: Project
    after: Project
    answers_solve: bool = False  # a solve of ``after`` may still be folded in


@dataclass(frozen=True)
class Change:
    """What a listener is told: why (cause), which aspects differ, the edit's label.

    cause : "edit", "undo", "redo", "result", "reset", "saved"
    """

    cause: str
    aspects: frozenset
    label: str = ""


def changed_aspects(old: Project | None, new: Project) -> frozenset:
    """The aspects (see :data:`ASPECTS`) in which ``new`` differs from ``old``."""
    if old is None:
        return frozenset(ASPECTS)
    out = set()
    if old.surface is not new.surface:
        out.add("surface")
    if not settings_equal(old.settings, new.settings):
        out.add("settings")
    if not labels_equal(old.settings, new.settings) or (old.region_name, old.candidates) != (
            new.region_name, new.candidates):  # kept candidate regions are labels too (flatweave.document.candidates)
        out.add("labels")
    if (old.units, old.shear_warning_deg, old.shear_limit_deg) != (
            new.units, new.shear_warning_deg, new.shear_limit_deg):
        out.add("display")
    if old.result is not new.result:
        out.add("result")
    if (old.name, old.source) != (new.name, new.source):
        out.add("name")
    if (old.piece_name, old.quantity, old.sequence, old.piece_index, old.piece_rosette, old.orientation) != (
            new.piece_name, new.quantity, new.sequence, new.piece_index, new.piece_rosette, new.orientation) \
            or len(old.others) != len(new.others) or any(a is not b for a, b in zip(old.others, new.others)) \
            or old.materials != new.materials or old.rosettes != new.rosettes:
        out.add("pieces")  # the materials and rosette tables too: a row added that no piece uses yet is an edit
    if len(old.sewings) != len(new.sewings) or any(a is not b for a, b in zip(old.sewings, new.sewings)):
        out.add("seams")
    if old.cut_plan != new.cut_plan:
        out.add("plan")
    return frozenset(out)


class Document:
    """The current project with undo and redo.

    path : where it was last saved or opened from (None: never saved)
    dirty : it differs from the saved (or opened) project
    """

    def __init__(self, project: Project, path: str | Path | None = None, limit: int = 100):
        self._project = project
        self._undo: list[Edit] = []
        self._redo: list[Edit] = []
        self._listeners: list[Callable[[Project, Change], None]] = []
        self.limit = int(limit)
        self.path = None if path is None else Path(path)
        self._saved: Project | None = project if path is not None else None
        self._pristine = path is None  # a new document nobody has touched yet
        self.revision = 0

    # ------------------------------------------------------------------ state
    @property
    def project(self) -> Project:
        return self._project

    @property
    def dirty(self) -> bool:
        return self._saved is not self._project

    @property
    def unsaved_work(self) -> bool:
        """Something here would be lost if the program ended now: the document
        differs from its file, or, never saved, has any edit or a result."""
        return self.dirty and not self._pristine

    @property
    def can_undo(self) -> bool:
        return bool(self._undo)

    @property
    def can_redo(self) -> bool:
        return bool(self._redo)

    @property
    def undo_label(self) -> str | None:
        return self._undo[-1].label if self._undo else None

    @property
    def redo_label(self) -> str | None:
        return self._redo[-1].label if self._redo else None

    @property
    def history(self) -> tuple[Edit, ...]:
        """The undo stack, oldest first."""
        return tuple(self._undo)

    # ------------------------------------------------------------------ listeners
    def subscribe(self, listener: Callable[[Project, Change], None]) -> Callable[[], None]:
        """Call ``listener(project, change)`` after every change; returns an unsubscribe function."""
        self._listeners.append(listener)

        def unsubscribe():
            if listener in self._listeners:
                self._listeners.remove(listener)
        return unsubscribe

    def _set(self, project: Project, cause: str, label: str = "") -> Change:
        old, self._project = self._project, project
        self.revision += 1
        if cause in ("edit", "undo", "redo", "result"):
            self._pristine = False
        change = Change(cause, changed_aspects(old, project), label)
        for listener in list(self._listeners):
            listener(project, change)
        return change

    # ------------------------------------------------------------------ edits
    def apply(self, label: str, project: Project, answers_solve: bool = True) -> Edit | None:
        """Make ``project`` current as one undoable edit called ``label``.

        Nothing happens (None) when ``project`` does not differ from the current
        one. ``answers_solve``: a solve started from ``project`` is folded into
        this edit when it finishes (see the module docstring).
        """
        project = pieces.follow_rosettes(self._project, project)
        if not changed_aspects(self._project, project):
            return None
        return self._record(Edit(label, self._project, self._shear_follows(project), answers_solve), "edit")

    def _shear_follows(self, project: Project) -> Project:
        """``project`` with the display's shear angles the active piece's material's when the edit changed
        that material's angles (a material chosen from the table, a table row edited, another piece made
        active by a delete) and not the display's itself: the colours and verdicts judge the cloth cut."""
        old, new = self._project.settings.material, project.settings.material
        shown = (project.shear_warning_deg, project.shear_limit_deg)
        if (old.warn_deg, old.lock_deg) == (new.warn_deg, new.lock_deg) \
                or shown != (self._project.shear_warning_deg, self._project.shear_limit_deg):
            return project
        return project.with_display(shear_warning_deg=float(new.warn_deg), shear_limit_deg=float(new.lock_deg))

    def _record(self, edit: Edit, cause: str) -> Edit:
        """``edit`` on the undo stack (the oldest beyond the limit dropped, redo cleared) and its
        project made current with ``cause``."""
        self._undo.append(edit)
        del self._undo[:-self.limit]
        self._redo.clear()
        self._set(edit.after, cause, edit.label)
        return edit

    def edit_settings(self, label: str, **changes) -> Edit | None:
        """An edit of FlattenSettings fields (validated; a SettingsError leaves the document as it was).

        A new material whose shear angles differ from the old one's brings them
        to the display too, in the same edit: the colours and the verdicts then
        judge the shear by the cloth's own warning and lock angles."""
        return self.apply(label, self._project.with_settings(**changes))

    def set_cut_plan(self, plan, label: str = "Cut plan") -> Edit | None:
        """The cut plan's settings ``plan`` (:class:`flatweave.document.cutsettings.CutPlanSettings`): one
        edit, which no solve answers (the pieces' results stay current)."""
        return self.apply(label, replace(self._project, cut_plan=plan), answers_solve=False)

    def edit_display(self, label: str, **changes) -> Edit | None:
        """An edit of units or shear angles (no solve answers it). The shear
        angles are the material's: they change with it, and a current result
        stays current, judged by the new angles (:func:`flatweave.method.pipeline.with_shear_angles`)."""
        project = self._project.with_display(**changes)
        if {"shear_warning_deg", "shear_limit_deg"} & set(changes):
            w, lock = project.shear_warning_deg, project.shear_limit_deg
            current = self._project.result_is_current
            project = project.with_settings(material=replace(project.settings.material, warn_deg=w, lock_deg=lock))
            if current:
                project = project.with_result(with_shear_angles(self._project.result, w, lock))
        return self.apply(label, project, answers_solve=False)

    def refit_surface(self, label: str, surface) -> Edit | None:
        """The surface refitted (a mesh's, to another tolerance: the same (u, v) map, so the
        settings, region and drawings stay) as one undoable edit; the result it had is dropped."""
        cur = self._project
        # every piece on the refitted surface moves with the active one: they share the source
        return self.apply(label, pieces.resurface(cur, cur.surface, surface).with_result(None), answers_solve=False)

    # ------------------------------------------------------------------ pieces
    def select_piece(self, k) -> Change | None:
        """Make piece ``k`` (an index or a name) the active one. Not an undo step:
        undo steps back through the edits, each with the piece it was made on active."""
        project = pieces.select(self._project, k)
        if project.piece_index == self._project.piece_index:
            return None
        return self._set(project, "select", f"Select {project.piece_name}")

    def add_piece(self, name: str | None = None, settings=None) -> Edit | None:
        """A new piece after the last, made active (:func:`flatweave.document.pieces.add`)."""
        project = pieces.add(self._project, name, settings)
        return self.apply(f"Add {project.piece_name}", project)

    def duplicate_piece(self, k, name: str | None = None, angle_deg: float | None = None) -> Edit | None:
        """A copy of piece ``k`` after it, at weft angle ``angle_deg`` if given, made active."""
        project = pieces.duplicate(self._project, k, name, angle_deg)
        return self.apply(f"Duplicate as {project.piece_name}", project)

    def remove_piece(self, k) -> Edit | None:
        """Delete piece ``k`` (not the only one)."""
        name = self._project.pieces[pieces.index_of(self._project, k)].name
        return self.apply(f"Delete {name}", pieces.remove(self._project, k), answers_solve=False)

    def rename_piece(self, k, name: str) -> Edit | None:
        """A new name for piece ``k`` (distinct from the others)."""
        name = " ".join(str(name).split())
        return self.apply("Rename piece", pieces.rename(self._project, k, name), answers_solve=False)

    def move_piece(self, k, to: int) -> Edit | None:
        """Piece ``k`` moved to position ``to`` in the list."""
        return self.apply("Move piece", pieces.move(self._project, k, to), answers_solve=False)

    def set_piece_quantity(self, k, quantity: int) -> Edit | None:
        return self.apply("Set quantity", pieces.set_quantity(self._project, k, quantity), answers_solve=False)

    def set_piece_sequence(self, k, sequence: int | None) -> Edit | None:
        return self.apply("Set sequence", pieces.set_sequence(self._project, k, sequence), answers_solve=False)

    def use_material(self, k, name: str) -> Edit | None:
        """Piece ``k`` cut from the table's material ``name``."""
        return self.apply(f"Material {name}", pieces.use_material(self._project, k, name))

    def set_materials(self, fabrics, label: str = "Edit materials") -> Edit | None:
        """A new materials table; the pieces cut from a row take its values (one edit)."""
        return self.apply(label, pieces.set_materials(self._project, fabrics))

    def orient_piece(self, k, rosette: str | None, orientation: float | None = None) -> Edit | None:
        """Piece ``k`` oriented ``orientation`` degrees from the rosette named ``rosette``
        (:func:`flatweave.document.pieces.orient`: None keeps its fibres; no rosette: its weft angle alone)."""
        name = self._project.pieces[pieces.index_of(self._project, k)].name
        return self.apply(f"Orient {name}", pieces.orient(self._project, k, rosette, orientation))

    def set_rosettes(self, rosettes, label: str = "Edit rosettes") -> Edit | None:
        """A new rosette table; the pieces oriented from a rosette follow it (one edit)."""
        return self.apply(label, pieces.set_rosettes(self._project, rosettes))

    # ------------------------------------------------------------------ darts and yarns
    def _dart_index(self, index: int) -> int:
        n = len(self._project.settings.darts)
        if not (isinstance(index, int) and 0 <= index < n):
            raise SettingsError(f"there is no dart {index!r} (the project has {n})")
        return index

    def _yarn_index(self, index: int) -> int:
        n = len(self._project.settings.yarns)
        if not (isinstance(index, int) and 0 <= index < n):
            raise SettingsError(f"there is no yarn constraint {index!r} (the project has {n})")
        return index

    def add_dart(self, dart, label: str | None = None) -> Edit | None:
        """Add a dart (a PlaneDart or CurveDart) after the others."""
        darts = self._project.settings.darts + (dart,)
        return self.apply(label or f"Add {dart.name}", self._project.with_settings(darts=darts))

    def replace_dart(self, index: int, dart, label: str = "Edit dart") -> Edit | None:
        """Put ``dart`` in the place of dart ``index`` (a moved or re-fitted dart)."""
        darts = list(self._project.settings.darts)
        darts[self._dart_index(index)] = dart
        return self.apply(label, self._project.with_settings(darts=tuple(darts)))

    def remove_dart(self, index: int) -> Edit | None:
        darts = list(self._project.settings.darts)
        gone = darts.pop(self._dart_index(index))
        return self.apply(f"Delete {gone.name}", self._project.with_settings(darts=tuple(darts)))

    def rename_dart(self, index: int, name: str) -> Edit | None:
        """A new name (labels only: the result stays current, no solve answers it)."""
        name = " ".join(str(name).split())
        if not name:
            raise SettingsError("a dart needs a name")
        darts = list(self._project.settings.darts)
        darts[self._dart_index(index)] = replace(darts[index], name=name)
        return self.apply("Rename dart", self._project.with_settings(darts=tuple(darts)), answers_solve=False)

    def set_dart_visible(self, index: int, visible: bool) -> Edit | None:
        """Show or hide a dart's curve (labels only, like a rename)."""
        darts = list(self._project.settings.darts)
        darts[self._dart_index(index)] = replace(darts[index], visible=bool(visible))
        return self.apply("Show dart" if visible else "Hide dart",
                          self._project.with_settings(darts=tuple(darts)), answers_solve=False)

    def add_yarn(self, yarn) -> Edit | None:
        """Add a yarn constraint (:class:`flatweave.method.energy.YarnConstraint`)."""
        yarns = self._project.settings.yarns + (yarn,)
        return self.apply(f"Constrain {yarn.label()}", self._project.with_settings(yarns=yarns))

    def replace_yarn(self, index: int, yarn, label: str = "Edit yarn constraint") -> Edit | None:
        yarns = list(self._project.settings.yarns)
        yarns[self._yarn_index(index)] = yarn
        return self.apply(label, self._project.with_settings(yarns=tuple(yarns)))

    def remove_yarn(self, index: int) -> Edit | None:
        yarns = list(self._project.settings.yarns)
        gone = yarns.pop(self._yarn_index(index))
        return self.apply(f"Remove {gone.label()} constraint",
                          self._project.with_settings(yarns=tuple(yarns)))

    # ------------------------------------------------------------------ seams
    def add_seam(self, seam, piece=None) -> Edit | None:
        """Draw ``seam`` (a :class:`flatweave.document.sewing.SeamLine`) on piece ``piece`` (default the
        active one): added to its shape's seams, or splitting it into panels when it is not a panel yet."""
        return self.apply(f"Add {seam.name}", sewing.add_seam(self._project, seam, piece))

    def replace_seam(self, shape, k, seam, label: str = "Edit seam") -> Edit | None:
        """Seam ``k`` (an index or a name) of ``shape`` (a Sewing or its name) replaced (a moved seam)."""
        return self.apply(label, sewing.replace_seam(self._project, shape, k, seam))

    def remove_seam(self, shape, k) -> Edit | None:
        """Seam ``k`` of ``shape`` deleted: the panels either side of it joined."""
        s = self._project.sewings[sewing.sewing_index(self._project, shape)]
        return self.apply(f"Delete {s.seams[s.seam_index(k)].name}", sewing.remove_seam(self._project, shape, k))

    def edit_seam(self, shape, k, label: str = "Edit seam", **changes) -> Edit | None:
        """Seam ``k`` of ``shape`` with its name or options changed (labels: no re-split, no solve)
        or its points (a re-split)."""
        lines = {"uv", "closed"} & set(changes)
        return self.apply(label, sewing.edit_seam(self._project, shape, k, **changes), answers_solve=bool(lines))

    def undo(self) -> bool:
        if not self._undo:
            return False
        edit = self._undo.pop()
        self._redo.append(edit)
        self._set(edit.before, "undo", edit.label)
        return True

    def redo(self) -> bool:
        if not self._redo:
            return False
        edit = self._redo.pop()
        self._undo.append(edit)
        self._set(edit.after, "redo", edit.label)
        return True

    def attach_result(self, result: FlattenResult, source: Project, label: str = "Solve") -> bool:
        """Record a finished solve that started from project ``source``.

        Refused (False) when the document has since moved to another surface or
        other settings: the result answers a question nobody asks any more.
        Otherwise the result is folded into the latest edit if that edit made
        ``source`` and is waiting for its solve, or becomes an edit ``label``.
        """
        cur = self._project
        if cur.surface is not source.surface or not settings_equal(cur.settings, source.settings) \
                or cur.piece_name != source.piece_name:  # another piece active, even of the same settings
            return False
        new = cur.with_result(result)
        top = self._undo[-1] if self._undo else None
        if top is not None and top.answers_solve and top.after is cur:
            self._undo[-1] = Edit(top.label, top.before, new, answers_solve=False)
            self._set(new, "result", top.label)
        else:
            self._record(Edit(label, cur, new, answers_solve=False), "result")
        return True

    def attach_results(self, results: dict, source: Project, label: str = "Solve all") -> list[str]:
        """Record finished solves of several pieces (``results``: piece name ->
        FlattenResult) started from project ``source``, as one undoable edit.
        A piece gets the result made from its settings as they are now (its
        own, or, renamed meanwhile, the one its settings were solved under; a
        piece whose settings changed since keeps its state; a matched seam's panel takes the ease its
        result was solved with, :mod:`flatweave.document.matching`); a result fits a
        piece only on the surface it was made on (its source refitted or
        replaced since: not taken). Returns the names of the pieces that got one."""
        cur = self._project
        pieces_now = list(cur.pieces)
        taken = []
        for k, piece in enumerate(pieces_now):
            mine = results.get(piece.name)
            # a matched seam's panel comes back eased (flatweave.document.matching): its settings take the ease
            unmatched = replace(piece.settings, ease=())
            fits = [r for r in ([mine] if mine is not None else []) + list(results.values())
                    if r.surface is piece.surface and (settings_equal(r.settings, piece.settings) or (
                        r.settings.ease and settings_equal(replace(r.settings, ease=()), unmatched)))]
            if fits:
                settings = piece.settings if not fits[0].settings.ease else replace(
                    piece.settings, ease=fits[0].settings.ease)
                pieces_now[k] = replace(piece, result=fits[0], settings=settings)
                taken.append(piece.name)
        if not taken:
            return []
        self._record(Edit(label, cur, pieces.with_pieces(cur, pieces_now, cur.piece_index), answers_solve=False),
                     "result")
        return taken

    # ------------------------------------------------------------------ documents
    def reset(self, project: Project, path: str | Path | None = None, saved: bool = True) -> None:
        """Start over with ``project`` (opened from ``path``, if given): history cleared.

        ``saved=False``: ``project`` is not what the file at ``path`` holds (a
        recovered autosave): the document is dirty and Save writes to ``path``.
        """
        self._undo.clear()
        self._redo.clear()
        self.path = None if path is None else Path(path)
        self._saved = project if (path is not None and saved) else None
        self._pristine = path is None and saved
        self._set(project, "reset")

    def mark_saved(self, path: str | Path) -> None:
        """The current project is now on disk at ``path``."""
        self.path = Path(path)
        self._saved = self._project
        self._set(self._project, "saved")


def unique_name(base: str, taken) -> str:
    """``base N`` with the smallest N >= 1 not among the names ``taken``."""
    taken = set(taken)
    n = 1
    while f"{base} {n}" in taken:
        n += 1
    return f"{base} {n}"
