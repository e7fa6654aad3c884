"""Tools > Suggest darts: :func:`flatweave.studies.autodarts.suggest_darts` on the document's
result, in a thread of its own, then a list to preview and accept them.

Only darts that keep every metric within the limits it was within, and whose
solve converged, are listed, with what the pattern's numbers say of each (usable,
how many warnings); a piece within every warning limit gets none, and the dialog
says why there are none, or fewer than asked for
(:attr:`flatweave.studies.autodarts.Suggestions.reason`).
Selecting a row previews that proposal: its dart in orange on the surface and
its re-solved piece (strain, pattern, metrics) in both views. Apply adds the
ticked proposals as one undoable edit; when they are the first k (the ones
each re-solve was made with) the k-th re-solve is the edit's result, so
nothing solves again. Close, or a document that moves on, puts the views back.
"""

from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtWidgets import (QDialog, QDialogButtonBox, QHBoxLayout, QLabel, QListWidget, QListWidgetItem,
                               QPushButton, QSpinBox, QVBoxLayout)

from flatweave.app.background import BackgroundCall
from flatweave.app.frames import FrameMaker
from flatweave.app.overlay import PREVIEW
from flatweave.method.result import judge_result
from flatweave.studies.autodarts import suggest_darts

__all__ = ["SuggestDialog", "proposal_text", "verdict_text"]


def verdict_text(result) -> str:
    """What the numbers say of a proposal's pattern, in a few words."""

    unusable = judge_result(result).unusable
    if unusable:
        return "not usable: " + ", ".join(unusable)
    n = len(result.warnings)
    return f"usable, {n} warning{'s' if n > 1 else ''}" if n else "usable, within every limit"


def proposal_text(p) -> str:
    m = p.metrics
    text = (f"{p.dart.name}: energy {-100 * p.gain:+.1f} %, boundary {m['boundary_error_pct']:.2f} %, "
            f"area {m['area_error_pct']:.2f} %, max shear {m['max_shear_deg']:.1f} deg, "
            f"beyond lock {m.get('area_beyond_lock_pct', 0.0):.2f} %")
    return text if p.result is None else f"{text} ({verdict_text(p.result)})"


class SuggestDialog(QDialog):
    """The suggestions of one result (the document's when opened)."""

    def __init__(self, window):
        super().__init__(window)
        self.setWindowTitle("Suggested darts")
        self.window_ = window
        self.project = window.document.project
        self.proposals: list = []
        self.call = BackgroundCall(self._done, self)
        lay = QVBoxLayout(self)
        row = QHBoxLayout()
        row.addWidget(QLabel("Up to"))
        self.count = QSpinBox(minimum=1, maximum=6, value=2)
        row.addWidget(self.count)
        row.addWidget(QLabel("darts"))
        self.suggest_button = QPushButton("Suggest")
        self.suggest_button.clicked.connect(self.start)
        row.addWidget(self.suggest_button)
        row.addStretch(1)
        lay.addLayout(row)
        self.status = QLabel("")
        self.status.setWordWrap(True)  # a reason is a sentence
        lay.addWidget(self.status)
        self.list = QListWidget()
        self.list.currentRowChanged.connect(self.preview)
        lay.addWidget(self.list)
        self.buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Apply | QDialogButtonBox.StandardButton.Close)
        self.buttons.button(QDialogButtonBox.StandardButton.Apply).clicked.connect(self.apply)
        self.buttons.button(QDialogButtonBox.StandardButton.Apply).setEnabled(False)
        self.buttons.rejected.connect(self.close)
        lay.addWidget(self.buttons)
        self.resize(560, 300)

    # ------------------------------------------------------------------ suggesting
    @property
    def busy(self) -> bool:
        return self.call.busy

    def start(self) -> None:
        if self.busy:
            return
        result = self.project.result
        if result is None or not self.project.result_is_current:
            self.status.setText("Solve first: darts are suggested for a converged piece.")
            return
        count = self.count.value()
        self.list.clear()
        self.proposals = []
        self.suggest_button.setEnabled(False)
        self.status.setText(f"Trying darts on the piece (up to {count})...")

        self.call.start(lambda: suggest_darts(result, count=count), "suggest-darts")

    def _done(self, proposals, error) -> None:
        self.suggest_button.setEnabled(True)
        if error is not None:
            self.status.setText(f"No suggestion: {error}")
            return
        if self.window_.document is None or self.window_.document.project is not self.project:
            self.status.setText("The document changed meanwhile: suggest again.")
            return
        self.proposals = list(proposals)
        reason = getattr(proposals, "reason", "")
        if not self.proposals:
            self.status.setText(f"No dart suggested: {reason}." if reason else "No dart suggested.")
            return
        fewer = f" No more: {reason}." if reason else ""
        self.status.setText(f"{len(self.proposals)} suggested; tick the darts to add and Apply "
                            f"(each was tried with the ones above it).{fewer}")
        for p in self.proposals:
            item = QListWidgetItem(proposal_text(p))
            item.setFlags(item.flags() | Qt.ItemFlag.ItemIsUserCheckable)
            item.setCheckState(Qt.CheckState.Checked)
            self.list.addItem(item)
        self.buttons.button(QDialogButtonBox.StandardButton.Apply).setEnabled(True)
        self.list.setCurrentRow(0)

    # ------------------------------------------------------------------ preview, apply
    def preview(self, row: int) -> None:
        if not (0 <= row < len(self.proposals)):
            return
        p = self.proposals[row]
        w = self.window_
        r = p.result
        frame = FrameMaker(r.surface, r.settings, r.metrics.get("boundary_length_3d"),
                           r.metrics.get("area_3d")).from_result(r)
        w.presenter.draw_frame(frame)
        w.view.draw("suggested dart", PREVIEW, [r.surface.points(p.dart.uv)])

    def checked(self) -> list[int]:
        return [k for k in range(self.list.count())
                if self.list.item(k).checkState() == Qt.CheckState.Checked]

    def apply(self) -> None:
        doc = self.window_.document
        rows = self.checked()
        if doc is None or not rows or doc.project is not self.project:
            return
        darts = self.project.settings.darts + tuple(self.proposals[k].dart for k in rows)
        label = "Add suggested dart" + ("s" if len(rows) > 1 else "")
        new = self.project.with_settings(darts=darts)
        prefix = rows == list(range(len(rows)))
        if prefix:  # the re-solve was made with exactly these darts: it is the edit's result
            new = new.with_result(self.proposals[rows[-1]].result)
        doc.apply(label, new, answers_solve=not prefix)  # with its result: the window starts no run
        self.project = doc.project
        self._restore()
        self.accept()

    def _restore(self) -> None:
        w = self.window_
        w.view.clear_layers(["suggested dart"], render=True)
        if w.document is not None:
            w.presenter.show_result(w.document.project)

    def closeEvent(self, event) -> None:
        self._restore()
        super().closeEvent(event)

    def reject(self) -> None:
        self._restore()
        super().reject()
