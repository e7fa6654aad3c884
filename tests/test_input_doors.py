"""Every file the command line reads goes through one guarded door
(``flatweave.files.read_input`` / ``check_input`` / ``parse_json``): a pipe or
a device is refused before it is opened (it would block or read for ever), a
file over its kind's limit before a byte is read, JSON nested deeper than
``MAX_JSON_DEPTH`` before it is parsed: one line, exit 2, nothing written.
A bad option value is one line naming the option, and numbers that overflow
print no numpy warning above their refusal. (Issue 45, items 1 and 3; the
suite's fuzz test is still to come.)
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

import flatweave.files
from flatweave.cli import main
from flatweave.document.project import ProjectError, load_project
from flatweave.errors import FlatweaveError
from flatweave.files import MAX_JSON_DEPTH, parse_json, read_input

pytestmark = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs are a POSIX feature")

# a door as the command line opens it: (argv before the file, argv after it)
DOORS = {
    "surface.json": (["info"], []),
    "mesh.stl": (["info"], []),
    "part.step": (["info"], []),
    "region.json": (["flatten", "octant", "--spacing", "0.2", "--region"], []),
    "warm.json": (["flatten", "octant", "--spacing", "0.2", "--warm-start"], []),
    "dart.json": (["flatten", "octant", "--spacing", "0.2", "--curve-dart"], []),
}


def _argv(name, path, out):
    before, after = DOORS[name]
    tail = ["--out", str(out)] if before[0] == "flatten" else []
    return [*before, str(path), *after, *tail]


@pytest.mark.parametrize("name", sorted(DOORS))
def test_a_pipe_at_any_door_is_refused_at_once(tmp_path, name):
    """Run in a child: a door that opened the pipe would block it for ever (the
    timeout only catches that hang; it is no measure of speed)."""
    fifo = tmp_path / name
    os.mkfifo(fifo)
    out = tmp_path / "out.json"
    p = subprocess.run([sys.executable, "-m", "flatweave", *_argv(name, fifo, out)], capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 2, p.stderr
    assert p.stderr.splitlines() == [f"flatweave: error: {fifo} is a pipe (FIFO), not a file"]
    assert not out.exists()


@pytest.mark.parametrize("name", sorted(DOORS))
def test_a_device_at_any_door_is_refused_without_reading_it(tmp_path, capsys, name):
    link = tmp_path / name
    link.symlink_to("/dev/zero")  # /dev/zero would read for ever
    out = tmp_path / "out.json"
    assert main(_argv(name, link, out)) == 2
    assert capsys.readouterr().err.splitlines() == [f"flatweave: error: {link} is a character device, not a file"]
    assert not out.exists()


@pytest.mark.parametrize("name", ["surface.json", "region.json", "warm.json", "dart.json"])
def test_json_nested_too_deep_is_refused_before_it_is_parsed(tmp_path, capsys, name):
    deep = tmp_path / name
    deep.write_text("[" * 100_000 + "]" * 100_000)
    out = tmp_path / "out.json"
    assert main(_argv(name, deep, out)) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith(f"flatweave: error: {deep}: not a ") and line.endswith(
        f"JSON nested more than {MAX_JSON_DEPTH} levels deep")
    assert not out.exists()


@pytest.mark.parametrize("name", sorted(DOORS))
def test_a_file_over_its_kinds_limit_is_refused_from_its_size(tmp_path, capsys, monkeypatch, name):
    big = tmp_path / name
    big.write_bytes(b" " * 4096)  # what it holds is never read
    monkeypatch.setattr(flatweave.files, "READ_LIMITS", {k: 1024 for k in flatweave.files.READ_LIMITS})
    out = tmp_path / "out.json"
    assert main(_argv(name, big, out)) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith(f"flatweave: error: {big} is 0 MB, more than the 0 MB read from a ")
    assert not out.exists()


def test_a_project_door_is_guarded_too(tmp_path):
    fifo = tmp_path / "p.flatweave"
    os.mkfifo(fifo)
    with pytest.raises(ProjectError, match="is a pipe"):
        load_project(fifo)
    deep = tmp_path / "deep.flatweave"
    deep.write_text('{"a": ' * 1000 + "1" + "}" * 1000)
    with pytest.raises(ProjectError, match="nested more than"):
        load_project(deep)


def test_brackets_inside_strings_do_not_count_and_a_long_name_stays_one_short_line(tmp_path):
    text = '{"label": "' + "[" * 500 + '\\"' + "{" * 500 + '", "points": [[1, [2]]]}'
    assert parse_json(text.encode(), "x.json", "region")["points"] == [[1, [2]]]
    long_name = tmp_path / ("n" * 240 + ".json")
    with pytest.raises(FlatweaveError) as e:
        read_input(long_name, "small")
    assert "\n" not in str(e.value) and len(str(e.value)) <= 400 and "no such file" in str(e.value)


@pytest.mark.parametrize("argv, words", [
    (["flatten", "octant", "--spacing", "abc"], "flatten: argument --spacing: 'abc' is not a number (above 0"),
    (["flatten", "octant"], "flatten: the following arguments are required: --spacing"),
    (["frobnicate"], "invalid choice: 'frobnicate'"),
])
def test_a_bad_option_is_one_line_naming_it_not_the_usage_block(capsys, argv, words):
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith("flatweave: error: ") and words in line and line.endswith("--help")


def test_numbers_that_overflow_print_nothing_above_the_one_line(tmp_path):
    """Run in a child, where Python shows numpy's RuntimeWarnings as a user would see them."""
    out = tmp_path / "r.json"
    p = subprocess.run([sys.executable, "-m", "flatweave", "flatten", "octant", "--spacing", "1e15", "--out",
                        str(out)], capture_output=True, text=True, timeout=300)
    assert p.returncode == 2
    (line,) = p.stderr.splitlines()
    assert line.startswith("flatweave: error: ") and "spacing 1e+15 is too large" in line
    assert not out.exists()
