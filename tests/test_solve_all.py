"""Solve all (issue 41, step 2; flatweave.document.solving and ``flatweave-cli
solve``): a project's pieces solved in worker processes give each piece the
result it gets alone, bit for bit; a piece that fails, or whose worker dies,
fails alone in one line and the others' results are kept and saved."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from flatweave import flatten
from flatweave.document import pieces as P
from flatweave.document.project import load_project, new_project, project_to_dict, save_project
from flatweave.document import solving
from flatweave.document.solving import WORKER_DIED, WORKER_BYTES, memory_workers, piece_nodes, solve_piece, solve_pieces
from flatweave.method.drape import BYTES_PER_NODE
from flatweave.errors import SettingsError
from flatweave.reading.examples import load_example


@pytest.fixture(scope="module")
def laminate():
    """Three plies of the woven octant at 0, +45 and 90 degrees, unsolved."""
    p = new_project(load_example("octant"), "lam", spacing=0.08)
    p = P.rename(p, 0, "ply 1")
    p = P.duplicate(p, 0, "ply 2", angle_deg=45.0)
    return P.duplicate(p, 1, "ply 3", angle_deg=90.0)


def crashing(job):
    """A worker's function whose piece "ply 2" kills its process (as the kernel's OOM killer would)."""
    if job[0] == "ply 2":
        os._exit(9)
    return solve_piece(job)


def refusing(job):
    """A worker's function whose piece "ply 3" fails with a one-line error."""
    if job[0] == "ply 3":
        raise SettingsError("ply 3 cannot be draped: a test's refusal")
    return solve_piece(job)


def _refused(job):
    try:
        return refusing(job)
    except SettingsError as exc:
        return job[0], None, str(exc), 0.0


def test_pieces_solved_in_the_pool_are_the_same_as_alone_bit_for_bit(laminate):
    seen = []
    solved, outcomes = solve_pieces(laminate, workers=2, on_done=seen.append)
    assert sorted(o.name for o in seen) == ["ply 1", "ply 2", "ply 3"]  # each reported as it finished
    assert [o.name for o in outcomes] == ["ply 1", "ply 2", "ply 3"] and not any(o.error for o in outcomes)
    assert solved.piece_name == laminate.piece_name  # the active piece stays active
    for piece in solved.pieces:
        alone = flatten(laminate.surface, piece.settings)
        r = piece.result
        assert r is not None and r.surface is laminate.surface
        np.testing.assert_array_equal(r.pattern.xy, alone.pattern.xy)
        np.testing.assert_array_equal(r.uv, alone.uv)
        assert r.metrics["energy"] == alone.metrics["energy"]
    for k in range(3):  # each piece's result is current when it is the active one
        assert P.select(solved, k).result_is_current


def test_named_pieces_only_and_here_with_one_worker(laminate):
    solved, outcomes = solve_pieces(laminate, ["ply 3", 0, "ply 3"], workers=1)
    assert [o.name for o in outcomes] == ["ply 3", "ply 1"]
    assert [p.result is not None for p in solved.pieces] == [True, False, True]
    with pytest.raises(SettingsError, match="no piece is named 'ply 9'"):
        solve_pieces(laminate, ["ply 9"])


def _where(job):
    """A worker's function that says which process solved the piece."""
    name, result, error, seconds = solve_piece(job)
    return name, result, f"pid {os.getpid()}", seconds


def test_the_pool_is_as_large_as_the_memory_holds_with_the_largest_pieces_at_once(laminate, monkeypatch):
    nodes = [piece_nodes(p.surface, p.settings) for p in laminate.pieces]
    solved, _ = solve_pieces(laminate, workers=1)
    made = [p.result.mesh.n_nodes for p in solved.pieces]
    assert all(0.7 * m <= n <= 1.5 * m for n, m in zip(nodes, made)), (nodes, made)  # the estimate is close
    one = WORKER_BYTES + BYTES_PER_NODE * max(nodes)
    monkeypatch.setattr(solving.drape, "available_memory", lambda: int(2.5 * one))
    assert memory_workers(4, nodes) == 2 and memory_workers(1, nodes) == 1
    monkeypatch.setattr(solving.drape, "available_memory", lambda: int(0.5 * one))
    assert memory_workers(4, nodes) == 1  # even one that does not fit runs: the drape refuses it in one line
    monkeypatch.setattr(solving.drape, "available_memory", lambda: None)
    assert memory_workers(3, nodes) == 3
    # memory for one at a time: asked for two workers, the pieces are solved one after another, here
    monkeypatch.setattr(solving.drape, "available_memory", lambda: int(1.5 * one))
    _, outcomes = solve_pieces(laminate, workers=2, fn=_where)
    assert {o.error for o in outcomes} == {f"pid {os.getpid()}"}


def test_a_piece_that_fails_fails_alone(laminate):
    solved, outcomes = solve_pieces(laminate, workers=2, fn=_refused)
    by_name = {o.name: o for o in outcomes}
    assert by_name["ply 3"].result is None and by_name["ply 3"].error == "ply 3 cannot be draped: a test's refusal"
    assert by_name["ply 1"].result is not None and by_name["ply 2"].result is not None
    assert [p.result is not None for p in solved.pieces] == [True, True, False]


def test_a_worker_that_dies_fails_its_piece_and_the_others_finish(laminate):
    solved, outcomes = solve_pieces(laminate, workers=2, fn=crashing)
    by_name = {o.name: o for o in outcomes}
    assert by_name["ply 2"].result is None and by_name["ply 2"].error == WORKER_DIED
    assert by_name["ply 1"].result is not None and by_name["ply 3"].result is not None
    assert [p.result is not None for p in solved.pieces] == [True, False, True]


def _timeless(doc):
    """A project document without the times its solves took (all else must be equal bit for bit)."""
    if isinstance(doc, dict):
        return {k: _timeless(v) for k, v in doc.items() if not k.endswith("seconds")}
    if isinstance(doc, list):
        return [_timeless(v) for v in doc]
    return doc


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "flatweave", *map(str, args)], capture_output=True, text=True,
                          timeout=600)


@pytest.mark.slow
def test_the_cli_solves_a_project_and_saves_every_result(laminate, tmp_path):
    path = save_project(laminate, tmp_path / "lam.flatweave")
    out = tmp_path / "solved.flatweave"
    p = _cli("solve", path, "--workers", "2", "--out", out)
    assert p.returncode == 0, p.stderr
    rows = p.stdout.splitlines()
    assert rows[0].split()[:3] == ["piece", "orient.", "status"]
    assert [r.split()[1] for r in rows[1:4]] == ["1", "2", "3"]
    assert all("converged" in r for r in rows[1:4]) and rows[-1] == f"-> {out}"
    back = load_project(out)
    assert all(piece.result is not None for piece in back.pieces) and back.result_is_current
    again, _ = solve_pieces(load_project(path), workers=1)
    # the CLI's pool and this process: bit for bit, but for the seconds each solve took
    assert _timeless(project_to_dict(back)) == _timeless(project_to_dict(again))
    # in place, one piece: the old file kept as a backup, the other pieces as they were
    p = _cli("solve", out, "--piece", "ply 2", "--quiet")
    assert p.returncode == 0 and p.stdout == ""
    # only the project's checks, which --quiet does not silence (the octant's fibres turn past 5 degrees)
    assert all(line.startswith("flatweave: warning: piece ") for line in p.stderr.splitlines())
    assert (tmp_path / "solved.backup-1.flatweave").is_file()
    assert project_to_dict(load_project(tmp_path / "solved.backup-1.flatweave")) == project_to_dict(back)
    assert _timeless(project_to_dict(load_project(out))) == _timeless(project_to_dict(back))  # ply 2 again
    # bad uses: one line, exit 2, nothing written
    for args, says in [(("--piece", "ply 9"), "no piece is named 'ply 9'"), (("--workers", "0"), "--workers"),
                       (("--out", tmp_path / "none" / "x.flatweave"), "does not exist")]:
        before = sorted(x.name for x in tmp_path.iterdir())
        p = _cli("solve", path, *args)
        assert p.returncode == 2 and says in p.stderr and p.stderr.count("\n") == 1, p.stderr
        assert sorted(x.name for x in tmp_path.iterdir()) == before
    p = _cli("solve", "octant")
    assert p.returncode == 2 and "solve takes a project" in p.stderr
