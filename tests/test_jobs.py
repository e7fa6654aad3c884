"""Job files (issue 41, item 4; flatweave.reading.jobs): a laminate as TOML, read
into a project of pieces (the bundled 24-ply example on the dome with no other
file), each ply's orientation measured from the rosette's 0 direction
projected at its seed, its boundary stepping in; solved by ``flatweave-cli
solve JOB.toml``; every mistake one line naming the file and line."""

from __future__ import annotations

import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from flatweave.document.project import load_project
from flatweave.errors import SettingsError
from flatweave.geometry.region import cover_for
from flatweave.method.rosette import rosette
from flatweave.reading.registry import open_path

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "resources" / "jobs" / "dome-laminate.toml"


@pytest.fixture(scope="module")
def dome_job():
    return open_path(EXAMPLE).project


def _signed_angle(zero, weft, normal) -> float:
    z = np.asarray(zero, dtype=float) - np.dot(zero, normal) * normal
    z /= np.linalg.norm(z)
    return math.degrees(math.atan2(np.dot(np.cross(z, weft), normal), np.dot(z, weft)))


def test_the_bundled_job_is_24_plies_at_their_orientations_from_the_rosette(dome_job):
    p = dome_job
    assert [x.name for x in p.pieces] == [f"P{k:02d}" for k in range(1, 25)]
    assert [x.sequence for x in p.pieces] == list(range(1, 25)) and p.units == "m"
    assert {x.settings.material.name for x in p.pieces[:12]} == {"carbon plain weave 200"}
    assert {x.settings.material.name for x in p.pieces[12:]} == {"glass twill 290"}
    assert {"carbon plain weave 200", "glass twill 290"} <= {f.name for f in p.materials}
    for k, piece in enumerate(p.pieces):
        # the weft at the seed, against the rosette's 0 direction (x) put in the tangent plane there
        r = rosette(p.surface, piece.settings.seed, piece.settings.angle_deg)
        want = [0.0, 45.0, -45.0, 90.0][k % 4]
        got = _signed_angle([1.0, 0.0, 0.0], r.weft, r.normal)
        assert abs((got - want + 180.0) % 360.0 - 180.0) < 1e-6, (piece.name, got, want)


def test_the_plies_step_in_ply_by_ply(dome_job):
    s = dome_job.surface
    covers = [cover_for(s, x.settings.region) for x in dome_job.pieces]
    areas = [c.area for c in covers]
    assert all(a > b for a, b in zip(areas, areas[1:]))  # each ply inside the one before: drop-offs
    for outer, inner in zip(covers, covers[1:]):
        assert outer.contains(inner.loops[0]).all()


def _job(tmp_path, body: str, name: str = "job.toml") -> Path:
    head = 'source = "octant"\nspacing = 0.12\nmaterial = "garment woven"\n[rosette]\norigin = [0, 0, 1]\n' \
           'zero = [1, 0, 0]\n'
    path = tmp_path / name
    path.write_text(head + body)
    return path


PLY = '[[ply]]\nname = "{name}"\norientation = {o}\n'


@pytest.mark.parametrize("body, line, says", [
    (PLY.format(name="a", o=0) + PLY.format(name="b", o=45) + 'material = "kevlar"\n', 10,
     "ply 'b': unknown material 'kevlar'"),
    (PLY.format(name="a", o='"x"'), 7, "ply 'a': its orientation (degrees) must be a number"),
    (PLY.format(name="a", o=0) + PLY.format(name="A", o=90), 10, "two plies are named 'A'"),
    (PLY.format(name="a", o=0) + 'boundary = { uv = [[0.5, 0.5], [1.5, 0.5], [1.5, 1.5]] }\n', 7, "ply 'a'"),
    (PLY.format(name="a", o=0) + 'colour = "red"\n', 7, "unknown key 'colour'"),
    (PLY.format(name="a", o=0) + 'offset = -10.0\n', 7, "ply 'a'"),
])
def test_a_bad_ply_is_one_line_naming_its_line(tmp_path, body, line, says):
    path = _job(tmp_path, body)
    with pytest.raises(SettingsError, match=re.escape(says)) as exc:
        open_path(path)
    assert str(exc.value).startswith(f"{path}:{line}: ") and "\n" not in str(exc.value)


@pytest.mark.parametrize("text, says", [
    ('source = "octant"\n[[ply\n', "not a job file"),
    ('spacing = 1\n', "a job names its surface"),
    ('source = "nowhere.step"\n', "source 'nowhere.step'"),
    ('source = "octant"\nspacing = 0.1\n[[ply]]\nname = "a"\nmaterial = "garment woven"\n', "needs a rosette"),
    ('source = "octant"\n[rosette]\norigin = [0, 0, 1]\nzero = [0, 0, 0]\n', "must not be zero"),
])
def test_a_bad_job_is_one_line(tmp_path, text, says):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(SettingsError, match=re.escape(says)) as exc:
        open_path(path)
    assert str(exc.value).startswith(str(path)) and "\n" not in str(exc.value)


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "flatweave", *map(str, args)], capture_output=True, text=True,
                          timeout=600)


@pytest.mark.slow
def test_the_cli_solves_a_job_into_a_project_beside_it(tmp_path):
    path = _job(tmp_path, PLY.format(name="P1", o=0) + 'sequence = 1\n' + PLY.format(name="P2", o=45) +
                'sequence = 2\noffset = -0.02\n' + PLY.format(name="P3", o=90) + 'sequence = 3\noffset = -0.04\n')
    p = _cli("solve", path, "--workers", "2", "--quiet")
    assert p.returncode == 0, p.stderr
    out = tmp_path / "job.flatweave"
    project = load_project(out)
    assert [x.name for x in project.pieces] == ["P1", "P2", "P3"]
    assert all(x.result is not None and x.result.status.startswith("converged") for x in project.pieces)
    assert path.read_text().startswith('source = "octant"')  # the job file itself untouched
    p = _cli("solve", path, "--out", tmp_path / "x.json")
    assert p.returncode == 2 and "written as a .flatweave file" in p.stderr


def test_a_piece_that_fails_fails_alone_with_its_own_exit_status(tmp_path, capsys):
    """A ply too small for the spacing fails in its solve (the drape's one line), the other is solved and the
    project saved: exit 3, neither 1 (an internal error) nor 2 (bad input, nothing written)."""
    from flatweave.cli import PIECES_FAILED, main

    tiny = 'boundary = { uv = [[0.5, 0.5], [0.51, 0.5], [0.51, 0.51], [0.5, 0.51]] }\n'
    path = _job(tmp_path, PLY.format(name="whole", o=0) + PLY.format(name="tiny", o=45) + tiny)
    assert main(["solve", str(path), "--workers", "1", "--quiet"]) == PIECES_FAILED == 3
    err = capsys.readouterr().err.strip().splitlines()
    failed = [line for line in err if line.startswith("flatweave: piece ")]
    assert len(failed) == 1 and failed[0].startswith("flatweave: piece 'tiny' failed: ") and "spacing" in failed[0]
    project = load_project(tmp_path / "job.flatweave")
    assert [x.result is not None for x in project.pieces] == [True, False]
