"""Matched seams (issue 42): the two panels of a seam solved so their sew lines come out equal in length.

Two panels flattened alone give a seam's two sides lengths that differ by the
strain each panel's lattice carries along it (a few tenths of a percent on a
doubly curved shape). A seam marked ``matched`` (:attr:`flatweave.document.sewing.SeamLine.matched`)
asks for equal sides. The constraint L_A = L_B across the seam is met by its
Lagrange multiplier: minimising E_A + E_B + lambda (L_A - L_B), each panel
carries a force along its sew line, which for springs is a change of their rest
length there. So each panel of a matched sew line is solved with the springs
along it eased (:attr:`flatweave.method.settings.FlattenSettings.ease`: longer
by ``a`` on one side, shorter by ``a`` on the other, fading over two spacings),
and ``a`` is found by the secant method on the sides' measured difference, all
the matched sew lines of a shape at once (each its own ``a``), a round solving
every panel they touch in worker processes (:func:`flatweave.document.solving.solve_pieces`).
The panels' results are then the fabric's own (energy, strain and pattern with
no ease); what matching cost is each panel's energy against its unmatched
solve's (``metrics["energy_unmatched"]``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from flatweave.document.pieces import pieces_of, with_pieces
from flatweave.document.project import settings_equal
from flatweave.document.sewing import split_of
from flatweave.document.solving import PieceOutcome, solve_pieces
from flatweave.method.seams import flat_sew_line, polyline_length
from flatweave.method.settings import MAX_EASE

__all__ = ["MatchReport", "match_seams", "matched_lines", "TARGET_PCT", "MAX_ROUNDS", "without_ease", "solve_all"]

TARGET_PCT = 0.05
"""A matched sew line's sides are solved to within this percentage of each other (the issue's target
is 0.1 %: the margin is the round-off of the outlines and the last solve's tolerance)."""
MAX_ROUNDS = 8
GAIN = 0.7
"""The first guess of -d ln L / d a: a sew line's flat length falls by about 0.7 a when its springs rest
longer by a (measured: 0.735 on the garment example's waist seam at spacing 0.02)."""


@dataclass(frozen=True)
class MatchReport:
    """What a matched solve did: per sew line (name -> (difference % before, after, ease amount)),
    the rounds of solves, whether every line reached :data:`TARGET_PCT`, and a one-line message."""

    lines: dict = field(default_factory=dict)
    rounds: int = 0
    reached: bool = True
    message: str = ""
    failed: tuple = ()

    def to_dict(self) -> dict:
        """The panels file's ``matching``: rounds, reached, message and per sew line its name, its sides'
        difference before and after (%), and the ease (a fraction: side A's springs along it longer by it,
        side B's shorter)."""
        return {"rounds": self.rounds, "reached": self.reached, "message": self.message,
                "lines": [{"name": k, "difference_pct_alone": v[0], "difference_pct": v[1], "ease": v[2]}
                          for k, v in self.lines.items()]}


@dataclass(frozen=True)
class _Line:
    sewing: str
    name: str
    uv: tuple
    panels: tuple  # the two pieces' names, side A first


def matched_lines(project) -> list:
    """The sew lines of the project's matched seams whose two panels are both pieces."""
    out = []
    for sewing in project.sewings:
        split = split_of(sewing)
        names = {p.name: n for p, n in zip(split.panels, sewing.panels)}
        matched = {s.name for s in sewing.seams if s.matched}
        for line in split.sews:
            sides = tuple(names.get(p) for p in line.panels)
            if line.seam in matched and len(sides) == 2 and None not in sides:
                out.append(_Line(sewing.name, line.name, tuple(map(tuple, np.asarray(line.uv).tolist())), sides))
    return out


def without_ease(project, names=None):
    """``project`` with the ease taken off the settings of pieces ``names`` (default all): as they
    are solved alone (a seam no longer matched, a panel re-split)."""
    pieces = tuple(replace(p, settings=replace(p.settings, ease=())) if p.settings.ease and (
        names is None or p.name in names) else p for p in pieces_of(project))
    return with_pieces(project, pieces, project.piece_index)


def _with_amounts(project, lines, amounts: dict):
    """``project`` with each matched panel's settings easing its sew lines by ``amounts`` (side A +a, B -a)."""
    ease: dict = {}
    for line in lines:
        a = float(amounts[line.name])
        ease.setdefault(line.panels[0], []).append((line.uv, a))
        ease.setdefault(line.panels[1], []).append((line.uv, -a))
    pieces = tuple(replace(p, settings=replace(p.settings, ease=tuple(ease[p.name]))) if p.name in ease else p
                   for p in pieces_of(project))
    return with_pieces(project, pieces, project.piece_index)


def _differences(project, lines) -> dict:
    """Per sew line, (L_A - L_B) / mean of its sides' flat lengths (None when a side is not solved)."""
    pieces = {p.name: p for p in pieces_of(project)}
    out = {}
    for line in lines:
        lengths = []
        for name in line.panels:
            r = pieces[name].result
            ok = r is not None and settings_equal(r.settings, pieces[name].settings)
            lengths.append(polyline_length(flat_sew_line(r, np.asarray(line.uv))) if ok else None)
        if None in lengths or sum(lengths) <= 0:
            out[line.name] = None
        else:
            out[line.name] = (lengths[0] - lengths[1]) / (0.5 * (lengths[0] + lengths[1]))
    return out


def match_seams(project, workers: int | None = None, stop=None, on_round=None):
    """``project`` with the panels of every matched seam solved so each sew line's sides agree within
    :data:`TARGET_PCT` (at most :data:`MAX_ROUNDS` rounds of solves), and a :class:`MatchReport`.
    ``on_round(k, differences)`` is told each round's relative differences; ``stop`` (an Event) ends
    it between rounds. A panel that fails to solve ends it, its error in the report."""
    lines = matched_lines(project)
    if not lines:
        return project, MatchReport()
    names = list(dict.fromkeys(n for line in lines for n in line.panels))
    # the unmatched solve: what each panel's energy is alone, and where the secant starts
    alone = without_ease(project, names)
    alone, outcomes = solve_pieces(alone, [n for n in names if not _current(alone, n)], workers, stop=stop)
    failed = tuple(f"{o.name}: {o.error}" for o in outcomes if o.result is None)
    if failed:
        return alone, MatchReport(rounds=0, reached=False, message=failed[0], failed=failed)
    base = {p.name: float(p.result.metrics["energy"]) for p in pieces_of(alone) if p.name in names}
    r0 = _differences(alone, lines)
    amounts = {line.name: 0.0 for line in lines}
    history = {line.name: [(0.0, r0[line.name])] for line in lines}
    current, r = alone, r0
    rounds = 0
    while rounds < MAX_ROUNDS and any(abs(r[n]) * 100.0 > TARGET_PCT for n in amounts):
        if stop is not None and stop.is_set():
            break
        for line in lines:
            seen = history[line.name]
            (a1, r1) = seen[-1]
            if abs(r1) * 100.0 <= TARGET_PCT and len(seen) > 1:
                continue  # this line holds (its neighbours' changes move it little)
            slope = -2.0 * GAIN  # r(a) ~ r0 - 2 GAIN a: side A shorter by GAIN a, side B longer
            if len(seen) > 1:
                (a0, q0) = seen[-2]
                if a1 != a0 and (r1 - q0) / (a1 - a0) < -0.2 * GAIN:  # a sane secant: r falls as a grows
                    slope = (r1 - q0) / (a1 - a0)
            amounts[line.name] = float(np.clip(a1 - r1 / slope, -MAX_EASE, MAX_EASE))
        trial = _with_amounts(current, lines, amounts)
        trial, outcomes = solve_pieces(trial, names, workers, stop=stop)
        rounds += 1
        failed = tuple(f"{o.name}: {o.error}" for o in outcomes if o.result is None)
        if failed:
            return trial, MatchReport(rounds=rounds, reached=False, message=failed[0], failed=failed)
        current, r = trial, _differences(trial, lines)
        for line in lines:
            history[line.name].append((amounts[line.name], r[line.name]))
        if on_round is not None:
            on_round(rounds, dict(r))
    # each matched panel's result with its unmatched energy beside its own: the cost of the match
    pieces = tuple(replace(p, result=replace(p.result, metrics={**p.result.metrics,
                                                                   "energy_unmatched": base[p.name]}))
                   if p.name in base and p.result is not None and p.settings.ease else p
                   for p in pieces_of(current))
    current = with_pieces(current, pieces, current.piece_index)
    reached = all(abs(r[n]) * 100.0 <= TARGET_PCT for n in amounts)
    report = {line.name: (100.0 * abs(r0[line.name]), 100.0 * abs(r[line.name]), amounts[line.name])
              for line in lines}
    worst = max(report.values(), key=lambda v: v[1])
    message = (f"{len(lines)} matched sew line{'s' if len(lines) != 1 else ''} within {TARGET_PCT:g} % in "
               f"{rounds} round{'s' if rounds != 1 else ''}" if reached else
               f"matched sew lines still up to {worst[1]:.3g} % apart after {rounds} rounds")
    return current, MatchReport(report, rounds, reached, message)


def _current(project, name: str) -> bool:
    p = next(q for q in pieces_of(project) if q.name == name)
    return p.result is not None and settings_equal(p.result.settings, p.settings)


def solve_all(project, pieces=None, workers: int | None = None, on_done=None, stop=None, cluster: str | None = None):
    """:func:`flatweave.document.solving.solve_pieces`, then, when a matched seam's panel was among the
    pieces solved (default every piece), the matched seams' panels solved to equal sides
    (:func:`match_seams`): (project, outcomes, MatchReport). A panel's outcome is then its matched
    result (its settings' ease with it); a matched panel not asked for is solved too, and its outcome
    added."""
    project, outcomes = solve_pieces(project, pieces, workers, on_done, stop=stop, cluster=cluster)
    lines = matched_lines(project)
    asked = {o.name for o in outcomes}
    if not any(n in asked for line in lines for n in line.panels) or any(o.result is None for o in outcomes) \
            or (stop is not None and stop.is_set()):
        return project, outcomes, MatchReport()
    project, report = match_seams(project, None if cluster is not None else workers, stop)
    by_name = {p.name: p for p in pieces_of(project)}
    outcomes = [PieceOutcome(o.name, by_name[o.name].result, o.error, o.seconds)
                if o.name in by_name and by_name[o.name].result is not None else o for o in outcomes]
    outcomes += [PieceOutcome(n, by_name[n].result) for n in dict.fromkeys(n for line in lines for n in line.panels)
                 if n not in asked and by_name[n].result is not None]
    return project, outcomes, report
