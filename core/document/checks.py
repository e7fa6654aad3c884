"""The project's consistency checks a shop expects (issue 41, item 6), as
one-line warnings of the project (:func:`project_checks`): shown under the
Pieces tab's list and printed by ``flatweave-cli solve``. They judge the
pieces together, where a result's own warnings judge one piece:

* two pieces of a laminate at the same sequence number;
* a piece cut from a material the table lacks;
* a piece whose region leaves the tool's surface (its domain);
* a solved piece whose fibres turn on the tool by more than ``FIBRE_TOL_DEG``
  from its orientation (the weft's deviation from the rosette direction
  projected cell by cell, :func:`flatweave.method.fibres.result_fibres`): cut
  with its warp along the roll, such a ply does not lie at its nominal angle
  everywhere;
* a sew line whose two sides, solved, differ in the flat by more than the
  tolerance (:data:`flatweave.method.seams.MATCH_PCT` and ``MATCH_MM``): the
  panels do not sew back together without easing (:func:`seam_rows`).
"""

from __future__ import annotations

import weakref

import numpy as np

from flatweave.document.pieces import pieces_of
from flatweave.document.project import settings_equal
from flatweave.document.sewing import SeamRow, panel_names, split_of
from flatweave.method.fibres import result_fibres
from flatweave.method.seams import MATCH_MM, MATCH_PCT, match_sews

__all__ = ["project_checks", "FIBRE_TOL_DEG", "seam_rows", "seam_warnings"]

FIBRE_TOL_DEG = 5.0  # a ply's fibres may turn this far from its nominal orientation (composites: 3 to 5 degrees)
DOMAIN_SLACK = 1e-9  # of the domain's width: a region on its edge is on the surface

_TURN: dict[int, float] = {}
"""The largest fibre turn of live results, by id (results are immutable; the Pieces tab judges
every piece at each document change, 2 ms a 2,500-node result)."""


def fibre_turn(result) -> float:
    """The largest |deviation| (degrees) of ``result``'s weft from the projected orientation; 0 with none."""
    turn = _TURN.get(id(result))
    if turn is None:
        dev = result_fibres(result).deviation_deg
        dev = np.abs(dev[np.isfinite(dev)])
        turn = _TURN[id(result)] = float(dev.max()) if len(dev) else 0.0
        weakref.finalize(result, _TURN.pop, id(result), None)
    return turn


def project_checks(project, fibre_tol_deg: float = FIBRE_TOL_DEG) -> list[str]:
    """The project's consistency warnings, one line each, in the pieces' order (empty: none)."""
    out = []
    pieces = project.pieces
    by_seq: dict[int, list[str]] = {}
    for p in pieces:
        if p.sequence is not None:
            by_seq.setdefault(p.sequence, []).append(p.name)
    for seq, names in sorted(by_seq.items()):
        if len(names) > 1:
            out.append(f"pieces {', '.join(repr(n) for n in names)} share sequence {seq}: a laminate lays one "
                       f"ply at each place in its stack")
    table = {f.name for f in project.materials}
    for p in pieces:
        dom = np.asarray(p.surface.domain, dtype=float)
        slack = DOMAIN_SLACK * (dom[:, 1] - dom[:, 0])
        material = p.settings.material.name
        if material not in table:
            out.append(f"piece {p.name!r} is cut from {material!r}, which the materials table lacks")
        region = p.settings.region
        if region is not None:
            uv = np.concatenate([np.asarray(loop, dtype=float) for loop in region.loops])
            if ((uv < dom[:, 0] - slack) | (uv > dom[:, 1] + slack)).any():
                out.append(f"piece {p.name!r} reaches beyond its surface: its region leaves the surface's "
                           f"domain")
        r = p.result
        if r is not None and settings_equal(r.settings, p.settings) and fibre_turn(r) > fibre_tol_deg:
            out.append(f"piece {p.name!r}: its fibres turn up to {fibre_turn(r):.1f} deg from its "
                       f"orientation on the tool (tolerance {fibre_tol_deg:g} deg)")
    return out + seam_warnings(project)


def seam_rows(project) -> list[SeamRow]:
    """Every sew line of the project's sewings (:mod:`flatweave.document.sewing`), in order, with each
    side's flat length when its panel's result is current (solved with its settings as they are)."""
    pieces = {p.name: p for p in pieces_of(project)}
    rows = []
    for sewing in project.sewings:
        split = split_of(sewing)
        names = panel_names(sewing)
        results = {}
        for panel in split.panels:
            piece = pieces.get(names[panel.name])
            r = None if piece is None else piece.result
            if r is not None and r.surface is piece.surface and settings_equal(r.settings, piece.settings):
                results[panel.name] = r
        sides_of = {m.name: m for m in match_sews(split, results)}
        asks = {s.name for s in sewing.seams if s.matched}
        for line in split.sews:
            sides = tuple(names[p] for p in line.panels)
            m = sides_of.get(line.name)
            cost = pct = None
            if m is not None:  # both sides current: their energy against their unmatched solves', if matched
                mine = [results[p].metrics for p in line.panels]
                if all("energy_unmatched" in q for q in mine):
                    alone = sum(q["energy_unmatched"] for q in mine)
                    cost = sum(q["energy"] for q in mine) - alone
                    pct = 100.0 * cost / alone if alone > 0 else None
            rows.append(SeamRow(line.name, line.seam, sewing.name, sides,
                                m.lengths if m is not None else tuple(None for _ in sides), line.seam in asks, pct,
                                cost))
    return rows


def seam_warnings(project) -> list[str]:
    """One line per sew line whose solved sides differ by more than the tolerance."""
    mm = 1000.0 * project.metres_per_unit
    return [f"sew line {r.name}: {r.panels[0]} {r.lengths[0]:.6g} and {r.panels[1]} {r.lengths[1]:.6g} long in "
            f"the flat, {r.difference_pct:.3g} % apart (over {MATCH_PCT:g} % and {MATCH_MM:g} mm)"
            for r in seam_rows(project) if r.over(mm)]
