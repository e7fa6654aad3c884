"""The materials table (issue 41, item 2; flatweave.method.materials): each
material's mechanics, shear angles and cutting-room data, bundled presets, the
project's table saved with it and shared as a file of its own, pieces cut
from a row, a row edited carrying its new values to its pieces; bad tables one
line."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest

from flatweave.document import pieces as P
from flatweave.document.history import Document
from flatweave.document.project import ProjectError, load_project, new_project, project_to_dict, save_project
from flatweave.errors import SettingsError
from flatweave.method.lattice import MATERIALS
from flatweave.method.materials import FABRICS, Fabric, fabric_kind, load_materials, materials_to_dict, save_materials
from flatweave.reading.examples import load_example

OLD = Path(__file__).parent / "data" / "projects"


def test_the_presets_say_what_they_are():
    assert {f.name: f.kind for f in FABRICS.values()} == {
        "carbon plain weave 200": "woven", "glass twill 290": "woven", "garment woven": "woven",
        "leather-like": "isotropic"}
    assert FABRICS["leather-like"].roll_width_mm is None  # hides, not a roll
    assert all(f.material.warn_deg < f.material.lock_deg for f in FABRICS.values())
    assert fabric_kind(MATERIALS["paper-isotropic"]) == "custom"  # 100:100:100 shears twice too stiffly


def test_a_table_file_round_trips_and_reads_into_another_project(tmp_path):
    mine = Fabric(replace(MATERIALS["woven"], name="my twill", lock_deg=45.0), 1000.0, 0.3, 300.0)
    path = save_materials((*FABRICS.values(), mine), tmp_path / "shop.json")
    back = load_materials(path)
    assert back == (*FABRICS.values(), mine)
    p = new_project(load_example("octant"), "tool", spacing=0.1)
    p = P.use_material(P.set_materials(p, back), 0, "my twill")
    assert p.settings.material.lock_deg == 45.0 and p.fabric("my twill").roll_width_mm == 1000.0


@pytest.mark.parametrize("damage, says", [
    (lambda d: d.update(format="x"), "not a flatweave materials table"),
    (lambda d: d["materials"].append(dict(d["materials"][0])), "two materials are named"),
    (lambda d: d["materials"][0].update(roll_width_mm=-5), "roll width must be a positive number"),
    (lambda d: d["materials"][0].update(thickness_mm="thin"), "thickness must be a positive number"),
    (lambda d: d["materials"][0].update(warn_deg=40.0, lock_deg=30.0), "warning angle"),
    (lambda d: d["materials"][0].pop("k_diag"), "lacks 'k_diag'"),
    (lambda d: d["materials"][0].update(k_weft=float("inf")), "k_weft must be a positive number"),
    (lambda d: d["materials"][0].update(name=""), "a material's name must be"),
])
def test_a_bad_table_is_refused_in_one_line(tmp_path, damage, says):
    d = materials_to_dict(FABRICS.values())
    damage(d)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(d, allow_nan=True))
    with pytest.raises(SettingsError, match=says) as exc:
        load_materials(path)
    assert "\n" not in str(exc.value) and "bad.json" in str(exc.value)


def test_pieces_are_cut_from_the_table_and_an_edited_row_reaches_them():
    doc = Document(new_project(load_example("octant"), "tool", spacing=0.1))
    assert [f.name for f in doc.project.materials] == [*FABRICS, "woven"]  # the presets and the piece's own
    doc.use_material(0, "carbon plain weave 200")
    doc.duplicate_piece(0, angle_deg=45.0)
    doc.add_piece("cover")
    doc.use_material("cover", "leather-like")
    assert [x.settings.material.name for x in doc.project.pieces] == ["carbon plain weave 200"] * 2 + ["leather-like"]
    # the carbon's lock angle raised in the table: both carbon plies take it, the leather stays
    table = tuple(replace(f, material=replace(f.material, lock_deg=35.0)) if f.name == "carbon plain weave 200"
                  else f for f in doc.project.materials)
    doc.set_materials(table)
    assert [x.settings.material.lock_deg for x in doc.project.pieces] == [35.0, 35.0, 40.0]
    doc.undo()
    assert [x.settings.material.lock_deg for x in doc.project.pieces] == [30.0, 30.0, 40.0]
    with pytest.raises(SettingsError, match="no material is named 'kevlar'"):
        doc.use_material(0, "kevlar")
    # a row no piece uses yet is an edit of its own (undoable), not nothing
    kevlar = Fabric(replace(MATERIALS["woven"], name="kevlar"), 1000.0)
    assert doc.set_materials((*doc.project.materials, kevlar)) is not None
    assert doc.project.fabric("kevlar") == kevlar
    doc.undo()
    assert doc.project.fabric("kevlar") is None


def test_the_table_is_saved_with_the_project_and_an_old_file_gets_one(tmp_path):
    p = new_project(load_example("octant"), "tool", spacing=0.1)
    mine = Fabric(replace(MATERIALS["isotropic"], name="felt", warn_deg=25.0, lock_deg=45.0), 1800.0)
    p = P.use_material(P.set_materials(p, (*p.materials, mine)), 0, "felt")
    back = load_project(save_project(p, tmp_path / "t.flatweave"))
    assert back.materials == p.materials and back.settings.material.name == "felt"
    assert project_to_dict(back) == project_to_dict(p)
    old = load_project(OLD / "v4-octant-region-solved.flatweave")
    assert [f.name for f in old.materials] == [*FABRICS, "woven"]
    doc = project_to_dict(p)
    doc["materials"] = [{"name": "x"}]
    (tmp_path / "bad.flatweave").write_text(json.dumps(doc))
    with pytest.raises(ProjectError, match="lacks 'k_weft'") as exc:
        load_project(tmp_path / "bad.flatweave")
    assert "\n" not in str(exc.value)
