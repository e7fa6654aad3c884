"""flatweave.document.candidates: several regions kept in a project, one active.
Keeping, naming, showing and hiding are labels (no solve changes); making one
active swaps it with the active region; the project file keeps them under an
optional key, so every frozen older file still reads and a file without any
kept region is byte-for-byte what it was."""

from __future__ import annotations

import json

import pytest

from flatweave.document.candidates import activate, keep_copy, remove, rename, set_visible
from flatweave.document.history import Document, changed_aspects
from flatweave.errors import SettingsError
from flatweave.reading.examples import example_path, load_example
from flatweave.document.project import load_project, new_project, project_to_dict, save_project
from flatweave.geometry.region import cover_for, region_from_spec


@pytest.fixture
def project():
    s = load_example("octant")
    p = new_project(s, "octant", str(example_path("octant")), 0.1)
    a = region_from_spec(s, {"uv": [[0.2, 0.2], [0.8, 0.2], [0.8, 0.8], [0.2, 0.8]]})
    return p.with_settings(region=a, seed=cover_for(s, a).default_seed)


def test_keep_draw_another_and_switch(project, tmp_path):
    s = project.surface
    a = project.settings.region
    kept = keep_copy(project)
    assert [c.name for c in kept.candidates] == ["region 2"] and kept.candidates[0].region == a
    assert changed_aspects(project, kept) == {"labels"}  # nothing to solve
    b = region_from_spec(s, {"uv": [[0.05, 0.05], [0.5, 0.05], [0.5, 0.5], [0.05, 0.5]]})
    drawn = kept.with_settings(region=b, seed=cover_for(s, b).default_seed)
    named = rename(rename(drawn, None, "ply B"), 0, "ply A")
    assert named.region_name == "ply B" and named.candidates[0].name == "ply A"
    # make ply A active: it swaps with ply B, the seed (outside A) moves to A's own
    on_a = activate(named, 0)
    assert on_a.settings.region == a and on_a.region_name == "ply A"
    assert on_a.candidates[0].name == "ply B" and on_a.candidates[0].region == b
    assert on_a.settings.seed == cover_for(s, a).default_seed
    assert "settings" in changed_aspects(named, on_a)
    hidden = set_visible(on_a, 0, False)
    assert not hidden.candidates[0].visible and changed_aspects(on_a, hidden) == {"labels"}
    # saved and read back: the same names, regions (drawn forms included) and visibility
    path = save_project(hidden, tmp_path / "two.flatweave")
    back = load_project(path)
    assert back.region_name == "ply A" and back.candidates == hidden.candidates
    assert back.settings.region == a
    assert remove(back, 0).candidates == ()
    # an edit of the document: undo brings the other region back
    doc = Document(named)
    doc.apply("Use ply A", on_a)
    doc.undo()
    assert doc.project.settings.region == b and doc.project.region_name == "ply B"


def test_bad_names_and_indices_are_one_line(project):
    kept = keep_copy(project)
    with pytest.raises(SettingsError, match="already a region called 'region'"):
        rename(kept, 0, "region")
    with pytest.raises(SettingsError, match="needs a name"):
        rename(kept, None, "  ")
    with pytest.raises(SettingsError, match="no kept region 3"):
        activate(kept, 3)


def test_a_project_without_kept_regions_writes_no_new_key(project):
    d = project_to_dict(project)
    assert "candidates" not in d
    json.dumps(d)
