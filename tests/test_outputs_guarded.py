"""Outputs never destroy what they replace (issue 45, item 4): a pipe, a device or a link to one
where an output goes is refused and left as it was; an output that is one of the run's inputs is
refused before any work; the result and the exports of a run are written all or nothing (an
export that fails leaves an earlier --out file untouched); a killed save's temporary files are
removed by the next save of that file."""

from __future__ import annotations

import os
import stat
import time

import pytest

import flatweave.cli
from flatweave.cli import main
from flatweave.errors import FlatweaveError
from flatweave.files import STALE_SECONDS, check_output, write_json
from flatweave.reading.examples import example_path


def _one_line(capsys) -> str:
    (line,) = capsys.readouterr().err.splitlines()
    return line


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs are a POSIX feature")
@pytest.mark.parametrize("flag, name", [("--out", "r.json"), ("--export", "p.svg")])
def test_a_pipe_or_a_link_to_a_device_where_an_output_goes_is_left_as_it_was(tmp_path, capsys, flag, name):
    fifo = tmp_path / name
    os.mkfifo(fifo)
    assert main(["flatten", "octant", "--spacing", "0.2", flag, str(fifo)]) == 2
    assert "is a pipe (FIFO), not a file, and is not replaced" in _one_line(capsys)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    link = tmp_path / f"null{fifo.suffix}"
    link.symlink_to(os.devnull)
    assert main(["flatten", "octant", "--spacing", "0.2", flag, str(link)]) == 2
    assert "is a character device, not a file, and is not replaced" in _one_line(capsys)
    assert link.is_symlink() and stat.S_ISCHR(os.stat(link).st_mode)


def test_an_output_that_is_an_input_is_refused_before_any_work(tmp_path, capsys):
    surface = tmp_path / "octant.json"
    surface.write_bytes(example_path("octant").read_bytes())
    before = surface.read_bytes()
    region = tmp_path / "region.json"
    region.write_text('{"uv": [[0.2, 0.2], [0.8, 0.2], [0.8, 0.8], [0.2, 0.8]]}')
    for argv in (["flatten", str(surface), "--spacing", "0.2", "--out", str(surface)],
                 ["flatten", str(surface), "--spacing", "0.2", "--region", str(region), "--out",
                  str(tmp_path / "." / "region.json")],
                 ["sweep", str(surface), "--spacing", "0.2", "--angles", "2", "--out", str(surface)]):
        assert main(argv) == 2
        assert "is one of this run's inputs" in _one_line(capsys)
    assert surface.read_bytes() == before and region.read_text().startswith('{"uv"')


def test_a_run_whose_export_fails_leaves_its_out_file_as_it_was(tmp_path, capsys, monkeypatch):
    out = tmp_path / "r.json"
    out.write_text("the earlier result")

    def failing(*args, **kwargs):
        raise FlatweaveError("cannot export p.svg: a test's failure")
    monkeypatch.setattr(flatweave.cli, "export_files", failing)
    assert main(["flatten", "octant", "--spacing", "0.2", "--out", str(out), "--export",
                 str(tmp_path / "p.svg")]) == 2
    assert "a test's failure" in _one_line(capsys)
    assert out.read_text() == "the earlier result" and not (tmp_path / "p.svg").exists()
    monkeypatch.undo()
    assert main(["flatten", "octant", "--spacing", "0.2", "--out", str(out), "--export",
                 str(tmp_path / "p.svg"), "--quiet"]) == 0
    assert out.read_text().startswith("{") and (tmp_path / "p.svg").is_file()


def test_a_killed_saves_temporary_files_go_at_the_next_save(tmp_path):
    path = tmp_path / "job.json"
    stale, fresh, other = (tmp_path / ".job.json.k1ll3d.tmp", tmp_path / ".job.json.s4v1ng.tmp",
                           tmp_path / ".other.json.k1ll3d.tmp")
    for f in (stale, fresh, other):
        f.write_bytes(b"half a save")
    old = time.time() - 2 * STALE_SECONDS
    os.utime(stale, (old, old))
    os.utime(other, (old, old))
    write_json(path, {"a": 1})
    assert not stale.exists()  # a killed save of this file
    assert fresh.exists()  # may be another save of it under way
    assert other.exists()  # another file's
    assert sorted(p.name for p in tmp_path.iterdir()) == [".job.json.s4v1ng.tmp", ".other.json.k1ll3d.tmp",
                                                          "job.json"]


def test_check_output_takes_a_new_name_or_a_regular_file(tmp_path):
    assert check_output(tmp_path / "new.json") == tmp_path / "new.json"
    (tmp_path / "old.json").write_text("{}")
    assert check_output(tmp_path / "old.json") == tmp_path / "old.json"
    with pytest.raises(FlatweaveError, match="is a folder"):
        check_output(tmp_path)
