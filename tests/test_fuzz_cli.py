"""Hostile input at every door of the command line (issue 45, item 6): a committed corpus of the
cases a fuzz run found (``tests/data/hostile``), and a hypothesis fuzz over the options' values.
Every run ends in success (exit 0) or in one line starting ``flatweave: error:`` with exit 2 and
nothing written: never an internal error (exit 1), a traceback, a warning printed above the line,
or a hang. The runs are in this process (pytest turns any warning into an error, so a numpy
warning on the way fails the test as it would show to a user), each on a budget that keeps a valid
run short (``--max-nodes``, ``--max-seconds``)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings as hsettings, strategies as st

from flatweave.cli import main

CORPUS = Path(__file__).parent / "data" / "hostile"
BUDGET = ["--max-nodes", "3000", "--max-seconds", "5", "--quiet"]


def _run(argv, capsys, tmp_path) -> tuple[int, list[str]]:
    """``main(argv)``'s exit code (argparse's SystemExit included) and its stderr lines."""
    before = set(tmp_path.iterdir())
    try:
        code = main(argv)
    except SystemExit as e:
        code = e.code
    lines = capsys.readouterr().err.splitlines()
    if code == 2:
        assert len(lines) == 1 and lines[0].startswith("flatweave: error: "), lines
        assert set(tmp_path.iterdir()) == before, "a refused run wrote something"
    else:
        assert code == 0, (code, lines)
        assert all(line.startswith("flatweave: warning: ") for line in lines), lines
    return code, lines


def _flatten(tmp_path, *args):
    return ["flatten", "octant", "--spacing", "0.2", *args, *BUDGET, "--out", str(tmp_path / "r.json")]


@pytest.mark.parametrize("args, says", [
    (["--curve-dart", "{c}/dart-tolerance-x.json"], "'tolerance' must be a positive number"),
    (["--curve-dart", "{c}/dart-huge-point.json"], "the drawn points reach 1e+308"),
    (["--region", "{c}/region-huge.json"], "region"),
    (["--region", "{c}/region-points-huge.json"], "region"),
    (["--warm-start", "{c}/warm-index-1e12.json"], "not one lattice"),
    (["--warm-start", "{c}/warm-index-not-whole.json"], "whole lattice indices"),
    (["--region-offset", "1e308"], "--region-offset"),
    (["--spacing", "1e-300"], "below a millionth"),
    (["--seam-allowance", "1e308", "--export", "{t}/p.svg"], "--seam-allowance"),
    (["--auto-darts", "1000000"], "--auto-darts"),
    (["--plane-dart", "1,0,0,nan"], "plane dart"),
    (["--yarn", "weft:0", "--yarn-plane", "0,0,0,1"], "yarn plane"),
])
def test_the_corpus_is_refused_in_one_line(tmp_path, capsys, args, says):
    args = [a.replace("{c}", str(CORPUS)).replace("{t}", str(tmp_path)) for a in args]
    code, lines = _run(_flatten(tmp_path, *args), capsys, tmp_path)
    assert code == 2 and says in lines[0], lines


def test_json_nested_a_hundred_thousand_deep_is_refused_in_one_line(tmp_path, capsys):
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    for door in ("--region", "--warm-start", "--curve-dart"):
        code, lines = _run(_flatten(tmp_path, door, str(deep)), capsys, tmp_path)
        assert code == 2 and "nested" in lines[0], lines


@pytest.mark.parametrize("args", [["--plane-dart", "1e308,-1e308,0,0"],
                                  ["--curve-dart", str(CORPUS / "dart-huge-view.json")]])
def test_a_plane_or_a_view_of_huge_numbers_is_the_one_it_means(tmp_path, capsys, args):
    """1e308 x - 1e308 y = 0 is the plane x = y; a view direction (1e308, 1e308, -1e308) is (1, 1, -1)."""
    code, _ = _run(_flatten(tmp_path, *args), capsys, tmp_path)
    assert code == 0 and json.loads((tmp_path / "r.json").read_text())["darts"]


# values a user, a script or a broken tool might pass: numbers at and past every edge, words, nothing
NUMBERS = st.sampled_from(["0", "-0", "1", "-1", "0.5", "1e-300", "1e-9", "1e308", "-1e308", "1e999", "nan",
                           "inf", "-inf", "99999999999999999999", "2", "45", "360", "1e15"])
WORDS = st.text(alphabet=st.characters(codec="utf-8", exclude_categories=["Cs", "Cc"]), max_size=8)
VALUES = st.one_of(NUMBERS, NUMBERS.map(lambda x: f"{x},{x}"), WORDS)
NUMERIC = ["--spacing", "--spacing-warp", "--angle", "--region-offset", "--tol", "--max-iter", "--auto-darts",
           "--fit-tolerance", "--seam-allowance", "--face", "--yarn-k", "--notch-every"]
LISTS = {"--seed": 2, "--plane-dart": 4, "--shear-angles": 2}


@st.composite
def _options(draw):
    argv = []
    for name in draw(st.lists(st.sampled_from(NUMERIC + list(LISTS)), min_size=1, max_size=3, unique=True)):
        if name in LISTS:
            value = ",".join(draw(st.lists(NUMBERS, min_size=LISTS[name], max_size=LISTS[name])))
            value = draw(st.sampled_from([value, value + ",1", draw(WORDS)]))
        else:
            value = draw(VALUES)
        argv += [name, value]
    return argv


@hsettings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(options=_options())
def test_any_option_values_end_in_a_result_or_one_line(tmp_path_factory, capsys, options):
    tmp = tmp_path_factory.mktemp("fuzz")
    if any(v.startswith("-") and not v[1:2].isdigit() and v[1:2] not in ("0", ".", "i", "n")
           for v in options[1::2]):
        options = [o.lstrip("-") if k % 2 else o for k, o in enumerate(options)]  # a value is not an option
    argv = ["flatten", "octant", "--spacing", "0.2", *options, *BUDGET, "--out", str(tmp / "r.json")]
    _run(argv, capsys, tmp)
