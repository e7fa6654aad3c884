"""Nothing a designer did is lost: older project files open, saves keep
backups and survive a killed writer, and autosaves outlive a crash
(flatweave.document.project versions, flatweave.document.recovery). The app's side: tests/test_app_recovery.py."""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from flatweave.document.history import Document
from flatweave.errors import FlatweaveError
from flatweave.reading.examples import load_example
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import flatten
from flatweave.document.project import (PROJECT_VERSION, UPGRADES, Project, load_project, project_problems,
                                        project_to_dict, save_project)
from flatweave.document.recovery import Session, backup_paths, find_orphans, recovery_dir, save_with_backups
from tests.helpers import FullDisk

REPO = Path(__file__).resolve().parents[1]
OLD = REPO / "tests" / "data" / "projects"


@pytest.fixture(scope="module")
def octant():
    return load_example("octant")


@pytest.fixture(scope="module")
def solved(octant):
    s = FlattenSettings(spacing=0.15)
    return Project(octant, s, name="solved", result=flatten(octant, s))


# ---------------------------------------------------------------------- schema versions
def test_every_older_version_has_an_upgrade_and_a_frozen_file():
    for version in range(1, PROJECT_VERSION):
        assert version in UPGRADES, f"no upgrade from project version {version}"
        assert list(OLD.glob(f"v{version}-*.flatweave")), f"no frozen file of project version {version}"


def test_a_version_1_project_with_a_result_opens():
    path = OLD / "v1-octant-solved.flatweave"
    raw = json.loads(path.read_text())
    assert raw["version"] == 1
    p = load_project(path)
    s = p.settings
    assert (p.name, p.units, p.shear_warning_deg, p.shear_limit_deg) == ("octant", "cm", 12.5, 27.0)
    assert (s.spacing, s.spacing_warp, s.angle_deg, s.material.name) == (0.12, 0.13, 10.0, "custom 300:200:5")
    assert [d.name for d in s.darts] == ["side", "collar"]
    assert s.darts[0].kind == "plane" and s.darts[1].kind == "curve"
    assert s.darts[1].visible is False and s.darts[1].view_dir == (0.0, 0.0, -1.0)
    np.testing.assert_array_equal(s.darts[1].handles, raw["darts"][1]["handles"])
    assert len(s.yarns) == 1 and s.yarns[0].kind == "warp"
    r = p.result
    assert r is not None and r.mesh.n_nodes == 102 == raw["result"]["metrics"]["nodes"]
    assert project_problems(p) == []
    assert r.history == ()  # version 1 kept no energy trace
    # the pattern rebuilt from the saved (u, v) is the one version 1 wrote
    np.testing.assert_allclose(r.pattern.xy, raw["result"]["nodes"]["xy"], atol=1e-9)
    assert r.metrics["energy"] == raw["result"]["metrics"]["energy"]


def test_a_version_1_file_re_saves_as_the_current_version(tmp_path):
    p = load_project(OLD / "v1-octant-solved.flatweave")
    out = save_project(p, tmp_path / "again.flatweave")
    doc = json.loads(out.read_text())
    assert doc["version"] == PROJECT_VERSION and doc["pieces"][0]["result"]["history"] == []
    again = load_project(out)
    assert project_to_dict(again) == project_to_dict(p)


def test_an_early_version_1_project_opens():
    p = load_project(OLD / "v1-early-octant.flatweave")
    assert p.result is None
    assert [d.name for d in p.settings.darts] == ["side", "collar"]
    assert all(d.visible for d in p.settings.darts)  # the field came later: visible by default
    assert p.settings.darts[1].handles is None and p.settings.darts[1].view_dir is None


def test_the_energy_history_is_saved(solved, tmp_path):
    r = solved.result
    assert len(r.history) >= r.metrics["iterations"] > 0  # one per iteration, and one per refill
    assert r.history[-1] == pytest.approx(r.metrics["energy"], rel=1e-9)
    back = load_project(save_project(solved, tmp_path / "h.flatweave"))
    assert back.result.history == r.history


def test_a_damaged_history_is_named(solved, tmp_path):
    doc = project_to_dict(solved)
    doc["pieces"][0]["result"]["history"] = [1.0, "x"]
    (tmp_path / "bad.flatweave").write_text(json.dumps(doc))
    with pytest.raises(FlatweaveError, match="history") as info:
        load_project(tmp_path / "bad.flatweave")
    assert "\n" not in str(info.value) and "bad.flatweave" in str(info.value)


# ---------------------------------------------------------------------- backups
def test_saves_keep_the_last_three_versions(octant, tmp_path):
    path = tmp_path / "piece.flatweave"
    names = [f"v{k}" for k in range(6)]
    for name in names:
        save_with_backups(Project(octant, FlattenSettings(spacing=0.1), name=name), path)
    assert load_project(path).name == "v5"
    assert [load_project(b).name for b in backup_paths(path)] == ["v4", "v3", "v2"]
    assert not backup_paths(path, 4)[3].exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["piece.flatweave"] + [b.name for b in backup_paths(path)])  # no temporary files left
    # saving the same project again makes no new backup
    save_with_backups(Project(octant, FlattenSettings(spacing=0.1), name="v5"), path)
    assert [load_project(b).name for b in backup_paths(path)] == ["v4", "v3", "v2"]


def test_a_backup_is_the_old_file_not_a_link_to_the_new_one(octant, tmp_path):
    path = tmp_path / "piece.flatweave"
    save_with_backups(Project(octant, FlattenSettings(spacing=0.1), name="old"), path)
    old_bytes = path.read_bytes()
    save_with_backups(Project(octant, FlattenSettings(spacing=0.1), name="new"), path)
    assert backup_paths(path)[0].read_bytes() == old_bytes
    assert load_project(path).name == "new"


def test_a_failed_save_leaves_the_old_file_and_says_so(octant, tmp_path, monkeypatch):
    path = tmp_path / "piece.flatweave"
    save_with_backups(Project(octant, FlattenSettings(spacing=0.1), name="kept"), path)
    before = path.read_bytes()

    FullDisk(monkeypatch, "fsync")
    with pytest.raises(FlatweaveError, match="No space left on device") as info:
        save_with_backups(Project(octant, FlattenSettings(spacing=0.1), name="lost"), path)
    assert "\n" not in str(info.value) and str(path) in str(info.value)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["piece.flatweave"]  # no backup rotated, no temp file


WRITER = textwrap.dedent("""
    import os, sys, time
    import flatweave.files
    from dataclasses import replace
    from flatweave.document.project import load_project
    from flatweave.document.recovery import save_with_backups
    real_fsync = os.fsync
    def slow_fsync(fd):  # a slow disk: the kill is likely to land between write and rename
        time.sleep(0.15)
        real_fsync(fd)
    flatweave.files.os.fsync = slow_fsync
    base = load_project(sys.argv[1])
    a, b = replace(base, name="A"), replace(base, name="B")
    target = sys.argv[2]
    print("ready", flush=True)
    k = 0
    while True:
        save_with_backups(a if k % 2 == 0 else b, target)
        k += 1
""")


@pytest.mark.slow
def test_killing_the_writer_mid_save_never_damages_the_file(solved, tmp_path):
    """A writer saving in a loop is killed (SIGKILL) at random moments: the file
    at the path is always a whole project, the old one or the new one."""
    src = save_project(solved, tmp_path / "src.flatweave")
    target = tmp_path / "out" / "piece.flatweave"
    target.parent.mkdir()
    save_project(solved.with_display(units="cm"), target)  # a first version, named "solved"
    rng = random.Random(7)
    mid_save = 0
    seen = set()
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    for _ in range(8):
        with subprocess.Popen([sys.executable, "-c", WRITER, str(src), str(target)], cwd=REPO, env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as proc:
            assert proc.stdout.readline().strip() == "ready", proc.stderr.read()
            time.sleep(rng.uniform(0.05, 0.8))
            proc.send_signal(signal.SIGKILL)
            proc.wait(timeout=30)
        temps = [p for p in target.parent.iterdir() if p.name.endswith(".tmp")]
        mid_save += bool(temps)
        for t in temps:
            t.unlink()
        p = load_project(target)  # never damaged
        assert p.name in ("solved", "A", "B")
        assert project_problems(p) == []
        seen.add(p.name)
        for b in backup_paths(target):
            if b.exists():
                assert load_project(b).name in ("solved", "A", "B")
    assert mid_save >= 3, f"only {mid_save} of 8 kills struck during a save: the test proves little"
    assert seen & {"A", "B"}, "the writer never finished a save"


# ---------------------------------------------------------------------- recovery files
def test_the_recovery_folder_follows_the_environment(tmp_path, monkeypatch):
    monkeypatch.setenv("FLATWEAVE_RECOVERY_DIR", str(tmp_path / "r"))
    assert recovery_dir() == tmp_path / "r"
    monkeypatch.delenv("FLATWEAVE_RECOVERY_DIR")
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "state"))
    assert recovery_dir() == tmp_path / "state" / "flatweave" / "recovery"


def test_a_live_session_is_not_an_orphan_and_a_closed_one_leaves_nothing(solved, tmp_path):
    s = Session(tmp_path)
    s.write(solved, tmp_path / "doc.flatweave")
    assert load_project(s.path).name == "solved"
    assert find_orphans(tmp_path) == []  # locked by this process's session
    s.close()
    assert list(tmp_path.iterdir()) == []


def test_a_cleared_session_offers_nothing(solved, tmp_path):
    s = Session(tmp_path)
    s.write(solved)
    s.clear()
    assert not s.path.exists()
    s.close()


def _release(orphans) -> set:
    for o in orphans:
        o.release()
    return {o.path for o in orphans}


def _killed_session(folder: Path, project_file: Path, document_path: str | None) -> None:
    """Run a session in another process that autosaves ``project_file`` and is killed."""
    code = textwrap.dedent(f"""
        import sys, time
        from flatweave.document.project import load_project
        from flatweave.document.recovery import Session
        s = Session({str(folder)!r})
        s.write(load_project({str(project_file)!r}), {document_path!r})
        print("written", flush=True)
        time.sleep(60)
    """)
    before = _release(find_orphans(folder)) if folder.exists() else set()
    with subprocess.Popen([sys.executable, "-c", code], cwd=REPO, stdout=subprocess.PIPE, text=True,
                          env={**os.environ, "PYTHONPATH": str(REPO)}) as proc:
        assert proc.stdout.readline().strip() == "written"
        assert _release(find_orphans(folder)) == before  # alive: not offered
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)


@pytest.mark.slow
def test_a_killed_session_is_offered_back(solved, tmp_path):
    folder = tmp_path / "recovery"
    src = save_project(solved, tmp_path / "src.flatweave")
    _killed_session(folder, src, "/home/designer/jacket.flatweave")
    found = find_orphans(folder)
    assert len(found) == 1
    orphan = found[0]
    assert orphan.name == "solved" and orphan.document_path == Path("/home/designer/jacket.flatweave")
    assert abs(orphan.saved_at - time.time()) < 120
    assert "solved" in orphan.describe() and "jacket.flatweave" in orphan.describe()
    assert find_orphans(folder) == []  # held while it is being offered: nobody else offers it
    back = orphan.load()
    assert project_to_dict(back) == project_to_dict(solved)
    orphan.release()  # "later": offered again at the next start
    again = find_orphans(folder)
    assert len(again) == 1
    again[0].discard()
    assert find_orphans(folder) == [] and list(folder.iterdir()) == []


@pytest.mark.slow
def test_several_orphans_newest_first_and_a_damaged_one_is_skipped(solved, octant, tmp_path):
    folder = tmp_path / "recovery"
    first = save_project(Project(octant, FlattenSettings(spacing=0.1), name="first"), tmp_path / "a.flatweave")
    second = save_project(Project(octant, FlattenSettings(spacing=0.1), name="second"), tmp_path / "b.flatweave")
    _killed_session(folder, first, None)
    time.sleep(0.05)
    _killed_session(folder, second, None)
    (folder / "session-junk.flatweave").write_text("{")
    found = find_orphans(folder)
    assert [o.name for o in found] == ["second", "first"]
    assert found[0].document_path is None and "never saved" in found[0].describe()
    for o in found:
        o.release()
    assert (folder / "session-junk.flatweave").exists()  # not ours to delete


@pytest.mark.slow
def test_stale_locks_of_sessions_that_never_autosaved_are_removed(tmp_path):
    code = textwrap.dedent(f"""
        import time
        from flatweave.document.recovery import Session
        Session({str(tmp_path)!r})
        print("up", flush=True)
        time.sleep(60)
    """)
    with subprocess.Popen([sys.executable, "-c", code], cwd=REPO, stdout=subprocess.PIPE, text=True,
                          env={**os.environ, "PYTHONPATH": str(REPO)}) as proc:
        assert proc.stdout.readline().strip() == "up"
        assert find_orphans(tmp_path) == [] and len(list(tmp_path.glob("*.lock"))) == 1  # alive: kept
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    assert find_orphans(tmp_path) == [] and list(tmp_path.iterdir()) == []


def test_an_unwritable_recovery_folder_is_one_line(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(FlatweaveError, match="recovery folder") as info:
        Session(blocker / "recovery")
    assert "\n" not in str(info.value)


# ---------------------------------------------------------------------- what counts as unsaved
def test_unsaved_work(octant, solved, tmp_path):
    fresh = Document(Project(octant, FlattenSettings(spacing=0.1)))
    assert fresh.dirty and not fresh.unsaved_work  # an untouched new document: nothing to lose
    fresh.edit_settings("Spacing", spacing=0.2)
    assert fresh.unsaved_work
    fresh.undo()
    assert fresh.unsaved_work  # the edit can be redone: still work
    opened = Document(solved, tmp_path / "x.flatweave")
    assert not opened.unsaved_work
    opened.edit_display("Units", units="cm")
    assert opened.unsaved_work
    opened.mark_saved(tmp_path / "x.flatweave")
    assert not opened.unsaved_work
    recovered = Document(solved)
    recovered.reset(solved, tmp_path / "x.flatweave", saved=False)
    assert recovered.unsaved_work and recovered.path == tmp_path / "x.flatweave"
    never_saved = Document(solved)
    never_saved.reset(solved, None, saved=False)
    assert never_saved.unsaved_work


def test_a_non_finite_number_is_refused_before_anything_is_written(tmp_path):
    from flatweave.files import write_json

    target = tmp_path / "x.json"
    target.write_text("old")
    with pytest.raises(FlatweaveError, match="not finite") as info:
        write_json(target, {"a": [1.0, float("nan")]})
    assert "\n" not in str(info.value) and str(target) in str(info.value)
    assert target.read_text() == "old" and list(tmp_path.iterdir()) == [target]
