"""The benchmark suite does not rot: every case of ``benchmarks/suite.py``
runs once at its smallest size and returns finite numbers under the keys it
declares. Parametrised over the registry, so a new case is covered as soon as
it is registered. No timing is asserted (the numbers are the suite's to
judge, not the tests'); reports go to a temporary folder, never into the tree.

The window's cases ask for pytest-xvfb's ``xvfb`` fixture (its display) and run in a
child process on it. The runs take about 35 s on two cores, so they are marked slow
(``make test-fast`` leaves them out; ``make test`` and CI run them)."""

from __future__ import annotations

import math

import pytest

from benchmarks import suite

CASES = [pytest.param(c, id=c.name) for c in suite.CASES]


def test_the_registry_names_each_case_once_with_sizes_from_smallest_to_full():
    names = [c.name for c in suite.CASES]
    assert len(names) == len(set(names))
    for c in suite.CASES:
        assert c.sizes and list(c.sizes) == sorted(c.sizes), c.name
        assert c.target.key in c.keys, c.name
        assert c.target.op in ("<", "<=", ">="), c.name
        assert c.measures and c.target.unit is not None, c.name
        # a {size: value} target names sizes the case runs at
        if isinstance(c.target.value, dict):
            assert set(c.target.value) <= set(c.sizes), c.name
        assert c.repeats >= 1


@pytest.mark.slow
@pytest.mark.parametrize("case", CASES)
def test_each_case_runs_at_its_smallest_size(case, tmp_path, request):
    if case.gui:
        request.getfixturevalue("xvfb")  # pytest-xvfb's display, which the case's child process inherits
        assert suite.has_display()
    rows = suite.run_cases([case], smallest=True)
    assert [(r.case.name, r.size, r.repeats) for r in rows] == [(case.name, case.smallest, 1)]
    row = rows[0]
    assert row.values is not None, row.note
    assert set(row.values) == set(case.keys)
    bad = {k: v for k, v in row.values.items() if not (isinstance(v, float) and math.isfinite(v))}
    assert not bad, bad
    out = tmp_path / "suite.md"
    out.write_text(suite.report(rows, f"smoke {case.name}", (0.0, 0.0)))
    text = out.read_text()
    assert f"| {case.name} | {case.smallest:,} {case.size_unit} |" in text


@pytest.mark.slow
def test_the_command_line_writes_one_results_file_where_told(tmp_path, capsys):
    out = tmp_path / "results" / "suite.md"
    assert suite.main(["--case", "eval_factor", "--case", "planar_garment", "--smallest", "--out", str(out)]) == 0
    text = out.read_text()
    assert "| case | size | measured (median) | target | met? |" in text
    assert "| eval_factor | 300 nodes |" in text and "| planar_garment | 200 nodes |" in text
    assert list(tmp_path.rglob("*")) == [out.parent, out]


def test_a_window_case_without_a_display_is_skipped_with_its_reason(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    case = next(c for c in suite.CASES if c.gui)
    (row,) = suite.run_cases([case], smallest=True)
    assert row.values is None and "no X display" in row.note and row.met is None
    assert "skipped: no X display" in suite.report([row], "no display", (0.0, 0.0))


def test_targets_judge_only_at_the_sizes_they_name():
    t = suite.Target("seconds", "<", {2_500: 0.5}, "s")
    assert t.met(0.4, 2_500) is True and t.met(0.6, 2_500) is False
    assert t.met(0.1, 300) is None and t.text(300) == "no target at this size"
    assert suite.Target("ratio", ">=", 20.0, "x").met(19.0, 100) is False
