"""Pieces solved on a Dask cluster (issue 41, "Beyond one machine";
``solve_pieces(..., cluster=ADDRESS)``, ``flatweave-cli solve --dask ADDRESS``),
against a ``distributed.LocalCluster`` of two worker processes: each piece's
result is the local pool's bit for bit; a piece that fails, or whose worker
dies, fails alone in one line and the others finish; a scheduler that does not
answer is one line, nothing solved."""

from __future__ import annotations

import threading

import dask
import distributed
import numpy as np
import pytest

from flatweave import cli
from flatweave.document import solving
from flatweave.document.project import load_project, save_project
from flatweave.document.solving import WORKER_DIED, solve_pieces
from flatweave.errors import SettingsError
from tests import test_solve_all
from tests.test_solve_all import crashing, refusing

laminate = test_solve_all.laminate  # the fixture: three plies of the octant, unsolved


@pytest.fixture(scope="module")
def address():
    """The scheduler's address of a LocalCluster: two worker processes of one thread each."""
    # allowed-failures 0: a task whose worker dies is KilledWorker at once, not after three more workers
    # restarted and killed (the scheduler's default); solve_pieces runs it again alone either way
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        # ":0", not None: with None the scheduler's HTTP server still takes port 8787, and a second cluster
        # (another pytest-xdist worker's) warns that it is in use
        cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                           dashboard_address=":0")
    try:
        yield cluster.scheduler_address
    finally:
        cluster.close()


def _same(a, b) -> bool:
    """Two results the same bit for bit, but for the seconds their solves took."""
    timeless = [{k: v for k, v in r.metrics.items() if not k.endswith("seconds")} for r in (a, b)]
    return (np.array_equal(a.uv, b.uv) and np.array_equal(a.xyz, b.xyz)
            and np.array_equal(a.pattern.xy, b.pattern.xy) and timeless[0] == timeless[1]
            and a.status == b.status and a.warnings == b.warnings)


def test_pieces_solved_on_the_cluster_are_the_pools_bit_for_bit(laminate, address):
    seen = []
    solved, outcomes = solve_pieces(laminate, cluster=address, on_done=seen.append)
    pooled, pool_outcomes = solve_pieces(laminate, workers=2)
    assert sorted(o.name for o in seen) == ["ply 1", "ply 2", "ply 3"]  # each reported as it finished
    assert [o.name for o in outcomes] == ["ply 1", "ply 2", "ply 3"] and not any(o.error for o in outcomes)
    assert solved.piece_name == laminate.piece_name
    for piece, pool_piece in zip(solved.pieces, pooled.pieces):
        assert piece.result.surface is laminate.surface  # the project's own surface, not the worker's copy
        assert _same(piece.result, pool_piece.result), piece.name
    assert [o.result.status for o in outcomes] == [o.result.status for o in pool_outcomes]


def test_a_piece_that_fails_on_the_cluster_fails_alone(laminate, address):
    solved, outcomes = solve_pieces(laminate, cluster=address, fn=refusing)
    by_name = {o.name: o for o in outcomes}
    assert by_name["ply 3"].result is None and by_name["ply 3"].error == "ply 3 cannot be draped: a test's refusal"
    assert by_name["ply 1"].result is not None and by_name["ply 2"].result is not None
    assert [p.result is not None for p in solved.pieces] == [True, True, False]


def test_a_worker_that_dies_on_the_cluster_fails_its_piece_and_the_others_finish(laminate, address):
    solved, outcomes = solve_pieces(laminate, cluster=address, fn=crashing)
    by_name = {o.name: o for o in outcomes}
    assert by_name["ply 2"].result is None and by_name["ply 2"].error == WORKER_DIED
    assert by_name["ply 1"].result is not None and by_name["ply 3"].result is not None
    assert [p.result is not None for p in solved.pieces] == [True, False, True]


def test_once_stopped_no_piece_starts_on_the_cluster(laminate, address):
    with distributed.Client(address, set_as_default=False) as client:
        client.wait_for_workers(2, timeout=120)  # both, though a worker killed above may still be restarting
    stop = threading.Event()
    # the cluster's two threads take two pieces; the first to finish stops the run, the other one finishes
    solved, outcomes = solve_pieces(laminate, cluster=address, on_done=lambda o: stop.set(), stop=stop)
    assert len(outcomes) == 2 and all(o.result is not None for o in outcomes)
    assert sum(p.result is not None for p in solved.pieces) == 2


def test_a_scheduler_that_does_not_answer_is_one_line_and_nothing_is_solved(laminate, monkeypatch):
    monkeypatch.setattr(solving, "CONNECT_SECONDS", 1.0)  # port 1 never answers: the wait is all the timeout
    seen = []
    with pytest.raises(SettingsError, match="tcp://127.0.0.1:1") as exc:
        solve_pieces(laminate, cluster="tcp://127.0.0.1:1", on_done=seen.append)
    assert "\n" not in str(exc.value) and not seen
    for bad in ("", "127.0.0.1", "http://127.0.0.1:8786"):  # no port, no scheme Dask knows: at once
        with pytest.raises(SettingsError) as exc:
            solve_pieces(laminate, cluster=bad)
        assert "\n" not in str(exc.value)
    with pytest.raises(SettingsError, match="not both"):
        solve_pieces(laminate, workers=2, cluster="tcp://127.0.0.1:1")


def test_the_cli_solves_a_project_on_the_cluster(laminate, address, tmp_path, capsys):
    path = save_project(laminate, tmp_path / "lam.flatweave")
    out = tmp_path / "solved.flatweave"
    assert cli.main(["solve", str(path), "--dask", address, "--out", str(out)]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == f"-> {out}"
    back = load_project(out)
    assert all(piece.result is not None and piece.result.status.startswith("converged") for piece in back.pieces)
    assert cli.main(["solve", str(path), "--dask", address, "--workers", "2"]) == 2
    err = capsys.readouterr().err
    assert "--dask and --workers contradict" in err and err.count("\n") == 1
