"""Suggested darts and the orientation sweep are ranked by what the designer
sees: a usable pattern (no metric past its bad limit) first, then what the
change improves; a dart that takes any metric past a limit it was within, or
whose solve does not converge, is not offered; a piece within every warning
limit gets no dart, and the reason says so."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

import flatweave.studies.autodarts as autodarts
from flatweave.studies.autodarts import suggest_darts
from flatweave.cli import main
from flatweave.method.darts import CurveDart
from flatweave.reading.examples import load_example
from flatweave.method.lattice import MATERIALS
from flatweave.method.metrics import metric_limits
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import flatten
from flatweave.method.result import judge_result, judged
from flatweave.studies.sweep import rank_rows, sweep

WITHIN = "every metric is within its warning limits"


def _crossed(before: dict, after: dict, limits: dict) -> list[str]:
    """The metric keys within a (warning or bad) limit before and past it after."""
    out = []
    for key, (warn, bad) in limits.items():
        a, b = before.get(key), after.get(key)
        if isinstance(a, (int, float)) and isinstance(b, (int, float)):
            if any(a <= t < b for t in (warn, bad)):
                out.append(key)
    return out


# ---------------------------------------------------------------------- the sweep's ranking
def _row(angle, beyond, shear, boundary, unusable=()):
    return {"angle_deg": angle, "seed": [0.5, 0.5], "area_beyond_lock_pct": beyond, "max_shear_deg": shear,
            "boundary_error_pct": boundary, "area_error_pct": 1.0, "unusable": list(unusable)}


def test_a_usable_row_ranks_before_an_unusable_one_with_less_shear():
    # the report's piece: 37.5 degrees has less shear but a pattern twice its boundary
    bad = _row(37.5, 0.0, 12.0, 98.0, ["boundary error 98 %", "area error 17 %"])
    good = _row(30.0, 0.3, 14.0, 48.0)
    worse = _row(45.0, 0.0, 11.0, 120.0, ["boundary error 120 %", "area error 25 %", "thread strain 4 %"])
    failed = {"angle_deg": 0.0, "seed": [0.5, 0.5], "error": "the drape failed"}
    assert rank_rows([worse, failed, bad, good]) == [good, bad, worse, failed]
    # within one class of usability the sweep's own order stands: less shear first
    calm = _row(20.0, 0.3, 13.0, 60.0)
    assert rank_rows([good, calm]) == [calm, good]


def test_sweep_rows_carry_their_verdict():
    surface = load_example("dome")
    s = FlattenSettings(spacing=0.15)
    res = sweep(surface, s, angles=2, workers=1)
    by_angle = {r["angle_deg"]: r for r in res.rows}
    # at 0 degrees the dome's corners shear past the lock angle; at 45 nowhere
    direct = judge_result(flatten(surface, s))
    assert by_angle[0.0]["unusable"] == list(direct.unusable) and direct.unusable
    assert by_angle[0.0]["status"] == flatten(surface, s).status
    assert by_angle[45.0]["unusable"] == []
    assert res.best is by_angle[45.0]
    assert res.to_dict()["rank_by"][0] == "unusable"


@pytest.mark.slow
def test_on_a_real_sweep_the_least_sheared_angle_opens_a_gap_and_does_not_win():
    """The saddle with a dart from its edge: at 45 degrees the largest shear is the lowest of
    the sweep (by more than the tie) but the dart's sides pull apart, leaving 2.3 % of the
    piece uncovered (past the 2 % bad limit); a usable angle wins."""
    dart = CurveDart(np.linspace([1.0, 0.093], [0.65, 0.378], 24), name="dart")
    res = sweep(load_example("saddle"), FlattenSettings(0.2, darts=(dart,)), angles=6, workers=2)
    calmest = min(res.rows, key=lambda r: r["max_shear_deg"])
    assert calmest["angle_deg"] == 45.0 and calmest["unusable"] == ["2.3 % uncovered"]
    assert all(r["max_shear_deg"] > calmest["max_shear_deg"] + 0.05 for r in res.rows if r is not calmest)
    assert res.best["unusable"] == [] and res.best["angle_deg"] == 30.0
    usable = [not r["unusable"] for r in res.rows]
    assert usable == sorted(usable, reverse=True)  # every usable row before every unusable one


# ---------------------------------------------------------------------- darts: a deterministic ruin
GOOD = CurveDart(np.array([[0.0, 0.5], [0.3, 0.5]]), name="good")
RUIN = CurveDart(np.array([[1.0, 0.5], [0.7, 0.5]]), name="ruin")

RUINS = {
    # the report's second suggestion: energy -25.7 %, boundary 153 %, area 55 %
    "outline": {"boundary_error_pct": 153.0, "area_error_pct": 55.0},
    # a solve stopped at the budget, its numbers otherwise the best
    "stopped": {"solver_status": "stopped at the iteration budget (1000)", "boundary_error_pct": 3.0,
                "area_error_pct": 0.3, "max_shear_deg": 4.0},
    # a dart whose sides pull apart: a gap in the cloth
    "gap": {"uncovered_pct": 3.4, "boundary_error_pct": 3.0, "area_error_pct": 0.3, "max_shear_deg": 4.0},
    # within the warning limit before, past it (not the bad one) after
    "warning": {"max_thread_strain_pct": 1.5, "boundary_error_pct": 3.0, "area_error_pct": 0.3,
                "max_shear_deg": 4.0},
}


@pytest.fixture(scope="module")
def warned():
    """The octant in a cloth whose warning angle (5 deg) its shear (9.5 deg) passes: darts are wanted."""
    material = replace(MATERIALS["woven"], warn_deg=5.0)
    r = flatten(load_example("octant"), FlattenSettings(0.1, material=material))
    assert r.warnings and r.usable and r.metrics["max_shear_deg"] > 5.0
    return r


def _stub(monkeypatch, base, outcomes):
    """Candidates GOOD and RUIN; a 're-solve' that gives the base with the metrics of ``outcomes[name]``."""
    monkeypatch.setattr(autodarts, "candidate_darts", lambda result, sites, lengths=None: [(0, GOOD), (1, RUIN)])

    def solve(job):
        _surface, settings, _state = job
        changes = outcomes["good" if np.array_equal(settings.darts[-1].uv, GOOD.uv) else "ruin"]
        return judged(replace(base, settings=settings, metrics={**base.metrics, **changes}))

    monkeypatch.setattr(autodarts, "_solve", solve)


@pytest.mark.parametrize("ruin", sorted(RUINS))
def test_a_dart_that_ruins_the_pattern_is_never_offered(monkeypatch, warned, ruin):
    e0 = warned.metrics["energy"]
    b0 = warned.metrics["boundary_error_pct"]
    # the good dart clears the shear warning but lengthens the outline a little (within its limit)
    good = {"energy": 0.85 * e0, "boundary_error_pct": b0 + 1.0, "max_shear_deg": 4.0}
    _stub(monkeypatch, warned, {"good": good, "ruin": {"energy": 0.743 * e0, **RUINS[ruin]}})
    got = suggest_darts(warned, count=1, workers=1)
    assert [p.dart.name for p in got] == ["suggested dart 1"]
    assert np.array_equal(got[0].dart.uv, GOOD.uv)
    assert got[0].result.usable and got[0].metrics["energy"] == pytest.approx(0.85 * e0)


def test_the_next_round_stops_once_every_metric_is_within_its_warning_limit(monkeypatch, warned):
    e0 = warned.metrics["energy"]
    _stub(monkeypatch, warned, {"good": {"energy": 0.85 * e0, "max_shear_deg": 4.0},
                                "ruin": {"energy": 0.743 * e0, **RUINS["outline"]}})
    got = suggest_darts(warned, count=3, workers=1)
    assert len(got) == 1 and got.reason == f"{WITHIN} with 1 suggested dart: no further dart needed"


def test_when_every_dart_ruins_the_pattern_none_is_offered_and_the_reason_counts_them(monkeypatch, warned):
    e0 = warned.metrics["energy"]
    _stub(monkeypatch, warned, {"good": {"energy": 0.8 * e0, **RUINS["stopped"]},
                                "ruin": {"energy": 0.743 * e0, **RUINS["outline"]}})
    got = suggest_darts(warned, count=2, workers=1)
    assert got == []
    assert got.reason == ("no dart tried helps: of 2 tried, 1 took a metric past a limit it was within "
                          "(boundary error 1, area error 1), 1 did not converge")


def test_a_usable_dart_ranks_before_one_that_lowers_the_energy_more(monkeypatch):
    """An unusable piece: the dart that makes it usable wins over one that lowers the energy more and not."""
    material = replace(MATERIALS["woven"], warn_deg=5.0, lock_deg=9.0)
    base = flatten(load_example("octant"), FlattenSettings(0.1, material=material))
    assert not base.usable
    e0 = base.metrics["energy"]
    shear = base.metrics["max_shear_deg"]
    _stub(monkeypatch, base, {"good": {"energy": 0.9 * e0, "max_shear_deg": 8.0, "area_beyond_lock_pct": 0.0},
                              "ruin": {"energy": 0.5 * e0, "max_shear_deg": shear - 0.1}})
    got = suggest_darts(base, count=1, workers=1)
    assert [p.dart.uv.tolist() for p in got] == [GOOD.uv.tolist()] and got[0].result.usable


# ---------------------------------------------------------------------- darts: real solves
@pytest.mark.slow
def test_on_the_saddle_no_suggested_dart_opens_a_gap():
    """The saddle's strongest candidates (energy -85 %) open gaps of over 3 % of its area:
    the pattern is not usable; the darts offered keep every metric within its limits."""
    base = flatten(load_example("saddle"), FlattenSettings(0.2))
    assert base.usable and base.warnings
    got = suggest_darts(base, count=2, workers=2)
    assert got, got.reason
    limits = metric_limits(base.settings.material, total_curvature=base.metrics["total_curvature"])
    before = base.metrics
    for p in got:
        assert p.result.usable, p.result.status
        assert p.metrics["solver_status"] == "converged"
        assert _crossed(before, p.metrics, limits) == []
        assert p.metrics["uncovered_pct"] <= limits["uncovered_pct"][0]
        before = p.metrics


@pytest.mark.slow
def test_when_every_dart_opens_a_gap_none_is_offered_and_the_reason_names_it():
    """On negative curvature a dart's sides pull apart: at 0.1 every candidate on the
    saddle leaves 1-6 % of it uncovered (past the 0.5 % warning limit it was within)."""
    base = flatten(load_example("saddle"), FlattenSettings(0.1))
    assert base.usable and base.metrics["uncovered_pct"] <= 0.5
    got = suggest_darts(base, count=1, workers=2)
    assert got == []
    assert got.reason.startswith("no dart tried helps: of 12 tried, 12 took a metric past a limit it was "
                                 "within (uncovered area 12")


@pytest.mark.slow
def test_an_unusable_dome_is_made_usable_and_nothing_gets_worse():
    base = flatten(load_example("dome"), FlattenSettings(0.15))
    assert not base.usable
    got = suggest_darts(base, count=1, workers=2)
    assert len(got) == 1 and got[0].result.usable
    limits = metric_limits(base.settings.material, total_curvature=base.metrics["total_curvature"])
    assert _crossed(base.metrics, got[0].metrics, limits) == []


def test_a_piece_within_every_warning_limit_gets_no_dart_and_says_why():
    base = flatten(load_example("garment"), FlattenSettings(0.05))
    assert base.warnings == () and base.usable
    got = suggest_darts(base, count=2, workers=2)
    assert got == [] and got.reason == f"{WITHIN}: no dart needed"


def test_a_rough_mesh_fit_alone_asks_for_no_dart():
    """The surface fitted to a mesh is the same whatever is cut: its deviation past its
    warning limit does not make a piece whose pattern is within every limit want darts."""
    base = flatten(load_example("garment"), FlattenSettings(0.05))
    rough = judged(replace(base, metrics={**base.metrics, "fit_max_deviation_pct": 1.0}))
    assert rough.warnings and rough.usable
    got = suggest_darts(rough, count=1, workers=2)
    assert got == [] and got.reason == ("every metric a dart can change is within its warning limits: "
                                        "no dart needed (the fitted surface's deviation past its own)")


def test_cli_says_why_no_dart_was_added(tmp_path, capsys):
    out = tmp_path / "r.json"
    assert main(["flatten", "garment", "--spacing", "0.05", "--auto-darts", "2", "--out", str(out)]) == 0
    err = capsys.readouterr().err.splitlines()
    assert f"0 of 2 suggested darts: {WITHIN}: no dart needed" in err
    assert not any("lowers the energy" in line for line in err)
    d = json.loads(out.read_text())
    assert d["suggested_darts"] == [] and not d["darts"]
