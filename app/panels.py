"""The side panels: the settings a user edits and the headline metrics.

:class:`SettingsPanel` shows a :class:`~flatweave.document.project.Project`'s settings and
reports every committed edit as ``settings_edited(label, changes)`` (fields of
FlattenSettings) or ``display_edited(label, changes)`` (units, shear angles);
it never changes the document itself: the window turns each report into one
undoable edit, and shows the project again (so a refused value snaps back).

Undo keys in a field: while a field holds text not yet committed, Ctrl+Z
(and Redo) edit that text, as in any text field; once it is committed (Enter,
or focus moved on) they go to the window's Undo and Redo, so they undo the
document's edit (:class:`DocumentUndoKeys`).
"""

from __future__ import annotations

import math

from PySide6.QtCore import QEvent, QObject, Qt, Signal
from PySide6.QtGui import QDoubleValidator, QKeySequence
from PySide6.QtWidgets import (QAbstractSpinBox, QCheckBox, QComboBox, QDoubleSpinBox, QFormLayout, QGroupBox,
                               QHBoxLayout, QLabel, QLineEdit, QSpinBox, QVBoxLayout, QWidget)

from flatweave.errors import SettingsError
from flatweave.method.lattice import MATERIALS, Material, parse_material
from flatweave.method.metrics import Verdict, metric_limits
from flatweave.method.result import judge_result
from flatweave.document.project import UNITS, Project

from flatweave.app.choices import solver_labels
from flatweave.geometry.region import with_offset

__all__ = ["NumberEdit", "SettingsPanel", "MetricsPanel", "DocumentUndoKeys"]


def _is_history_key(event) -> bool:
    keys = QKeySequence.StandardKey
    if event.matches(keys.Undo) or event.matches(keys.Redo):
        return True
    combo = event.keyCombination()
    return combo.key() == Qt.Key.Key_Y and combo.keyboardModifiers() == Qt.KeyboardModifier.ControlModifier


class DocumentUndoKeys(QObject):
    """An event filter on line edits and spin boxes: with no uncommitted text
    in the field (its line edit's ``isModified()`` is false), the undo and redo
    keys are not the field's, so the window's Undo and Redo shortcuts get them.
    :meth:`watch` installs it and clears a field's modified flag when it commits."""

    def watch(self, field: QLineEdit | QAbstractSpinBox) -> None:
        edit = field.lineEdit() if isinstance(field, QAbstractSpinBox) else field
        for target in {field, edit}:  # a spin box hands the key on to its line edit itself
            target.installEventFilter(self)
        field.editingFinished.connect(lambda: edit.setModified(False))

    def eventFilter(self, obj, event) -> bool:
        if event.type() != QEvent.Type.ShortcutOverride:
            return False
        edit = obj.lineEdit() if isinstance(obj, QAbstractSpinBox) else obj
        if isinstance(edit, QLineEdit) and not edit.isModified() and _is_history_key(event):
            event.ignore()  # not overridden: the window's shortcut takes it
            return True
        return False


class NumberEdit(QLineEdit):
    """A line edit for one positive number, shown with ``%g`` (0.04, 1e-09).

    ``value_committed(float)`` when the user finishes editing a new valid value.
    """

    value_committed = Signal(float)

    def __init__(self, value: float, minimum: float = 0.0, maximum: float = 1e12, parent=None):
        super().__init__(parent)
        v = QDoubleValidator(minimum, maximum, 12, self)
        v.setNotation(QDoubleValidator.Notation.ScientificNotation)
        self.setValidator(v)
        self._value = float(value)
        self.setText(f"{value:g}")
        self.editingFinished.connect(self._commit)

    def value(self) -> float:
        return self._value

    def set_value(self, value: float) -> None:
        self._value = float(value)
        self.setText(f"{value:g}")

    def _commit(self) -> None:
        try:
            v = float(self.text().replace(",", "."))
        except ValueError:
            self.set_value(self._value)
            return
        if not math.isfinite(v) or v == self._value:
            self.set_value(self._value)
            return
        self._value = v
        self.value_committed.emit(v)


def _spin(lo: float, hi: float, step: float, decimals: int, suffix: str = "") -> QDoubleSpinBox:
    s = QDoubleSpinBox()
    s.setRange(lo, hi)
    s.setSingleStep(step)
    s.setDecimals(decimals)
    s.setKeyboardTracking(False)  # one change per commit, not per keystroke
    if suffix:
        s.setSuffix(suffix)
    return s


class SettingsPanel(QWidget):
    """The settings form (see the module docstring)."""

    settings_edited = Signal(str, dict)
    display_edited = Signal(str, dict)
    input_error = Signal(str)  # a value the panel itself cannot read (one line)

    def __init__(self, parent=None):
        super().__init__(parent)
        self._loading = False
        self._project: Project | None = None
        layout = QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)

        mesh_box = QGroupBox("Fabric and mesh")
        form = QFormLayout(mesh_box)
        self.material = QComboBox()
        for name, m in MATERIALS.items():
            self.material.addItem(f"{name} ({m.ratio})", name)
        self.material.addItem("custom ratio", "custom")
        self.material.setToolTip("Spring constants weft : warp : diagonal")
        self.ratio = QLineEdit()
        self.ratio.setPlaceholderText("weft:warp:diag, e.g. 500:500:1")
        self.ratio.setToolTip("A custom spring-constant ratio WEFT:WARP:DIAG")
        form.addRow("Material", self.material)
        form.addRow("Ratio", self.ratio)
        self.spacing = NumberEdit(0.05, 0.0)
        self.spacing.setToolTip("Rest length of the weft springs, in model units")
        self.spacing_warp = NumberEdit(0.05, 0.0)
        self.spacing_warp.setToolTip("Rest length of the warp springs, in model units")
        self.same_warp = QCheckBox("same as weft")
        warp_row = QHBoxLayout()
        warp_row.addWidget(self.spacing_warp, 1)
        warp_row.addWidget(self.same_warp)
        form.addRow("Weft spacing", self.spacing)
        form.addRow("Warp spacing", warp_row)
        self.seed_u = _spin(0.0, 1.0, 0.05, 3)
        self.seed_v = _spin(0.0, 1.0, 0.05, 3)
        for s, d in ((self.seed_u, "u"), (self.seed_v, "v")):
            s.setToolTip(f"Seed point: fraction of the parameter domain along {d}")
        seed_row = QHBoxLayout()
        seed_row.addWidget(QLabel("u"))
        seed_row.addWidget(self.seed_u, 1)
        seed_row.addWidget(QLabel("v"))
        seed_row.addWidget(self.seed_v, 1)
        form.addRow("Seed", seed_row)
        self.angle = _spin(-180.0, 180.0, 5.0, 1, " deg")
        self.angle.setToolTip("Weft direction at the seed, from the u direction towards v")
        form.addRow("Weft angle", self.angle)
        self.region_offset = NumberEdit(0.0, -1e12, 1e12)
        self.region_offset.setToolTip("Move the drawn region's boundary along the surface by this distance, in "
                                      "model units: positive outwards, negative inwards (0: as drawn)")
        form.addRow("Region offset", self.region_offset)
        layout.addWidget(mesh_box)

        solve_box = QGroupBox("Solver")
        form = QFormLayout(solve_box)
        self.solver = QComboBox()
        for key, text in solver_labels().items():
            self.solver.addItem(text, key)
        self.tol = NumberEdit(1e-9, 0.0, 1.0)
        self.tol.setToolTip("Stop when an iteration lowers the energy by less than this fraction")
        self.max_iter = QSpinBox()
        self.max_iter.setRange(1, 1_000_000)
        self.max_iter.setKeyboardTracking(False)
        self.auto_rerun = QCheckBox("Re-run when a setting changes")
        self.auto_rerun.setChecked(True)
        form.addRow("Method", self.solver)
        form.addRow("Tolerance", self.tol)
        form.addRow("Max iterations", self.max_iter)
        form.addRow(self.auto_rerun)
        layout.addWidget(solve_box)

        show_box = QGroupBox("Model and display")
        form = QFormLayout(show_box)
        self.units = QComboBox()
        for u in UNITS:
            self.units.addItem(u, u)
        self.units.setToolTip("What one unit of the surface's coordinates is")
        self.shear_warning = _spin(0.5, 89.0, 1.0, 1, " deg")
        self.shear_limit = _spin(1.0, 90.0, 1.0, 1, " deg")
        form.addRow("Model units", self.units)
        form.addRow("Shear warning", self.shear_warning)
        form.addRow("Shear limit", self.shear_limit)
        layout.addWidget(show_box)

        self.undo_keys = DocumentUndoKeys(self)
        for field in (self.ratio, self.spacing, self.spacing_warp, self.tol, self.seed_u, self.seed_v, self.angle,
                      self.region_offset, self.max_iter, self.shear_warning, self.shear_limit):
            self.undo_keys.watch(field)
        self._connect()

    # ------------------------------------------------------------------ wiring
    def _connect(self) -> None:
        self.material.activated.connect(self._material_chosen)
        self.ratio.editingFinished.connect(self._ratio_committed)
        self.spacing.value_committed.connect(lambda v: self._settings("Weft spacing", spacing=v))
        self.spacing_warp.value_committed.connect(lambda v: self._settings("Warp spacing", spacing_warp=v))
        self.same_warp.toggled.connect(self._same_warp_toggled)
        self.seed_u.valueChanged.connect(lambda _v: self._seed())
        self.seed_v.valueChanged.connect(lambda _v: self._seed())
        self.angle.valueChanged.connect(lambda v: self._settings("Weft angle", angle_deg=float(v)))
        self.region_offset.value_committed.connect(self._offset_committed)
        self.solver.activated.connect(lambda _i: self._settings("Solver", solver=self.solver.currentData()))
        self.tol.value_committed.connect(lambda v: self._settings("Tolerance", tol=v))
        self.max_iter.valueChanged.connect(lambda v: self._settings("Max iterations", max_iter=int(v)))
        self.units.activated.connect(lambda _i: self._display("Units", units=self.units.currentData()))
        self.shear_warning.valueChanged.connect(
            lambda v: self._display("Shear warning angle", shear_warning_deg=float(v)))
        self.shear_limit.valueChanged.connect(
            lambda v: self._display("Shear limit angle", shear_limit_deg=float(v)))

    def _settings(self, label: str, **changes) -> None:
        if not self._loading:
            self.settings_edited.emit(label, changes)

    def _display(self, label: str, **changes) -> None:
        if not self._loading:
            self.display_edited.emit(label, changes)

    def _seed(self) -> None:
        self._settings("Seed", seed=(float(self.seed_u.value()), float(self.seed_v.value())))

    def _offset_committed(self, value: float) -> None:
        """The drawn region offset by ``value`` (its seed kept while inside): one settings edit."""
        p = self._project
        if self._loading or p is None:
            return

        s = p.settings
        try:
            region, seed = with_offset(p.surface, s.region, value, s.spacing, s.spacing_warp, s.seed)
        except SettingsError as exc:
            self.region_offset.set_value(s.region.drawn.offset if s.region is not None and s.region.drawn else 0.0)
            self.input_error.emit(f"Region offset: {exc}")
            return
        self._settings("Region offset", region=region, seed=seed)

    def _same_warp_toggled(self, on: bool) -> None:
        self.spacing_warp.setEnabled(not on)
        if on:
            self._settings("Warp spacing", spacing_warp=None)
        else:
            self._settings("Warp spacing", spacing_warp=self.spacing.value())

    def _material_chosen(self, _index: int) -> None:
        key = self.material.currentData()
        self.ratio.setEnabled(key == "custom")
        if key == "custom":
            current = self._project.settings.material if self._project else MATERIALS["woven"]
            self._settings("Material", material=Material(f"custom {current.ratio}", current.k_weft,
                                                          current.k_warp, current.k_diag,
                                                          current.warn_deg, current.lock_deg))
        else:
            self._settings("Material", material=MATERIALS[key])

    def _ratio_committed(self) -> None:
        if self._loading or self._project is None:
            return
        text = self.ratio.text().strip()
        if not text or text == self._project.settings.material.ratio:
            return
        try:
            material = parse_material(text)
        except SettingsError as exc:
            self.ratio.setText(self._project.settings.material.ratio)
            self.input_error.emit(str(exc))
            return
        if material.name in MATERIALS:  # a preset's name typed in
            self._settings("Material", material=material)
        else:
            current = self._project.settings.material  # a new ratio keeps the cloth's shear angles
            self._settings("Material", material=Material(f"custom {material.ratio}", material.k_weft,
                                                          material.k_warp, material.k_diag,
                                                          current.warn_deg, current.lock_deg))

    # ------------------------------------------------------------------ showing a project
    def set_project(self, project: Project) -> None:
        """Show ``project``'s values (without reporting them as edits)."""
        self._project = project
        s = project.settings
        self._loading = True
        try:
            preset = MATERIALS.get(s.material.name)  # a preset with other shear angles is still that preset
            key = s.material.name if preset is not None and preset.same_constants(s.material) else "custom"
            self.material.setCurrentIndex(self.material.findData(key))
            self.ratio.setText(s.material.ratio)
            self.ratio.setEnabled(key == "custom")
            self.spacing.set_value(s.spacing)
            same = s.spacing_warp is None
            self.same_warp.setChecked(same)
            self.spacing_warp.set_value(s.spacing if same else s.spacing_warp)
            self.spacing_warp.setEnabled(not same)
            self.seed_u.setValue(float(s.seed[0]))
            self.seed_v.setValue(float(s.seed[1]))
            self.angle.setValue(float(s.angle_deg))
            drawn = s.region.drawn if s.region is not None else None
            self.region_offset.set_value(drawn.offset if drawn is not None else 0.0)
            self.region_offset.setEnabled(drawn is not None)
            idx = self.solver.findData(s.solver)
            self.solver.setCurrentIndex(idx if idx >= 0 else 0)
            self.tol.set_value(s.tol)
            self.max_iter.setValue(int(s.max_iter))
            self.units.setCurrentIndex(self.units.findData(project.units))
            self.shear_warning.setValue(float(project.shear_warning_deg))
            self.shear_limit.setValue(float(project.shear_limit_deg))
        finally:
            self._loading = False


METRIC_COLOURS = ("#207020", "#b36b00", "#c00000")  # within the limits, past the warning, past the bad one


def metric_colour(value: float, limits: tuple[float, float]) -> str:
    """The colour of a value against its (warning, bad) thresholds
    (:func:`flatweave.method.metrics.metric_limits`)."""
    warn, bad = limits
    return METRIC_COLOURS[2 if value > bad else 1 if value > warn else 0]


class MetricsPanel(QWidget):
    """Headline numbers of the pattern shown: energy, boundary and area error,
    max shear, max thread strain, uncovered share, size, nodes, iterations,
    solver status and the result's warnings. Every number that has a limit
    (:func:`flatweave.method.metrics.metric_limits`: the material's and the project's
    shear angles) is coloured against it."""

    ROWS = (("energy", "Energy EN"), ("boundary", "Boundary error"), ("area", "Area error"),
            ("shear", "Max shear"), ("beyond_lock", "Beyond lock angle"), ("thread", "Max thread strain"),
            ("uncovered", "Uncovered"),
            ("size", "Pattern size"), ("nodes", "Nodes / springs"), ("iterations", "Iterations"),
            ("status", "Status"), ("warnings", "Warnings"), ("fit", "Mesh fit"))
    LIMITED = (("boundary", "boundary_error_pct"), ("area", "area_error_pct"), ("shear", "max_shear_deg"),
               ("beyond_lock", "area_beyond_lock_pct"), ("thread", "max_thread_strain_pct"),
               ("uncovered", "uncovered_pct"))

    def __init__(self, parent=None):
        super().__init__(parent)
        form = QFormLayout(self)
        form.setContentsMargins(6, 4, 6, 4)
        form.setVerticalSpacing(2)
        self.labels: dict[str, QLabel] = {}
        for key, title in self.ROWS:
            lab = QLabel("-")
            lab.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
            self.labels[key] = lab
            form.addRow(title, lab)
        self.labels["warnings"].setWordWrap(True)
        self.labels["status"].setWordWrap(True)  # a verdict names every metric past its limit: long
        self.labels["fit"].setWordWrap(True)
        self.fit_text = "-"  # the surface's fit to its mesh (kept through results: it is the surface's)
        self.warnings: tuple[str, ...] = ()
        self._warned = None  # (result, angles) the warnings were made for

    def text(self, key: str) -> str:
        return self.labels[key].text()

    def clear(self) -> None:
        self.warnings = ()
        for lab in self.labels.values():
            lab.setText("-")
            lab.setStyleSheet("")
        self.labels["fit"].setText(self.fit_text)

    def set_fit(self, text: str) -> None:
        """Show how the surface follows the mesh it was fitted to ("-": not a mesh)."""
        self.fit_text = text
        self.labels["fit"].setText(text)

    def show_frame(self, frame, project: Project, stale: bool = False) -> None:
        st = frame.stats
        u = project.units
        self.labels["energy"].setText("- (draping)" if frame.draping else f"{frame.energy:.6g}")
        for key, name in (("boundary", "boundary_error_pct"), ("area", "area_error_pct")):
            self.labels[key].setText(f"{st[name]:.3f} %" if name in st else "- (pattern pending)")
        self.labels["shear"].setText(f"{st.get('max_shear_deg', math.nan):.2f} deg")
        self.labels["thread"].setText(f"{st.get('max_thread_strain_pct', math.nan):.4f} %")
        lock = project.settings.material.lock_deg  # the metric is the material's (the result's), not the view's
        self.labels["beyond_lock"].setText(f"{st['area_beyond_lock_pct']:.2f} % of the area (lock {lock:g} deg)"
                                           if "area_beyond_lock_pct" in st else "-")
        self.labels["uncovered"].setText(f"{st['uncovered_pct']:.2f} %" if "uncovered_pct" in st else "-")
        limits = metric_limits(project.settings.material, project.shear_warning_deg, project.shear_limit_deg,
                               total_curvature=st.get("total_curvature"))
        for key, name in self.LIMITED:
            value = st.get(name)
            lab = self.labels[key]
            if value is None or not math.isfinite(value) or name not in limits:
                lab.setStyleSheet("")
            else:
                lab.setStyleSheet(f"color: {metric_colour(value, limits[name])}; font-weight: bold")
        if frame.pattern is not None and len(frame.pattern.outline):
            ext = frame.pattern.outline.max(axis=0) - frame.pattern.outline.min(axis=0)
            self.labels["size"].setText(f"{ext[0]:.4g} x {ext[1]:.4g} {u}")
        self.labels["nodes"].setText(f"{st.get('nodes', 0):,} / {st.get('springs', 0):,}")
        self.labels["iterations"].setText(str(frame.iteration))
        # a finished frame's own result (a preview's: a suggested dart, a sweep's row), else the document's
        verdict = self._verdict(project, frame.result or project.result) if frame.final else None
        self.warnings = verdict.warnings if verdict is not None else ()
        if verdict is not None:
            status = verdict.status
        else:
            status = frame.status if frame.final else "draping..." if frame.draping else "solving..."
        if stale:
            status += " (settings changed since; Run to update)"
        self.labels["status"].setText(status)
        level = 0 if verdict is None else 2 if verdict.unusable else 1 if verdict.warnings else 0
        self.labels["status"].setStyleSheet(f"color: {METRIC_COLOURS[level]}; font-weight: bold" if level else "")
        self.labels["warnings"].setText("\n".join(self.warnings) if self.warnings else "none" if frame.final else "-")

    def _verdict(self, project: Project, r) -> Verdict | None:
        """Result ``r``'s :class:`flatweave.method.metrics.Verdict` for the project's shear angles
        (made once per result and angles: the shear warning needs every cell's shear); the
        core's judgement, as the CLI and the result file have it (:func:`flatweave.method.pipeline.judge_result`)."""
        if r is None:
            return None
        key = (r, project.shear_warning_deg, project.shear_limit_deg)
        if self._warned is None or self._warned[0] is not r or self._warned[1:3] != key[1:]:
            try:
                made = judge_result(r, project.shear_warning_deg, project.shear_limit_deg)
            except ValueError:  # angles the settings panel refuses anyway
                made = Verdict(tuple(r.warnings), (), r.status)
            self._warned = (*key, made)
        return self._warned[3]
