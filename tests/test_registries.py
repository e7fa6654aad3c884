"""The reader and exporter registries: a file format is one call, and every front
end (the CLI's help, choices and errors; the dialogs' filters) reads the registry."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from flatweave.reading import registry as readers
from flatweave.cli import main
from flatweave.errors import FlatweaveError, SettingsError
from flatweave.reading.examples import example_info, example_names, example_path, load_example
from flatweave.export.registry import (FORMATS, ExportOption, ExportOptions, dialog_filter, export_bytes,
                                       export_options, exporter_for, register_exporter, unregister_exporter)
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.document.project import PROJECT_SUFFIX, Project, new_project, save_project
from flatweave.reading.opened import Opened
from flatweave.reading.registry import open_path, reader_for, register_reader, unregister_reader

REPO = Path(__file__).resolve().parents[1]


# ---------------------------------------------------------------------- a toy format of each kind
SEPARATOR = ExportOption("separator", "choice", "space", "what separates the toy's counts", "Separator (TXT)",
                         choices={"space": "a space", "comma": "a comma"})


def _txt_writer(result, options, sheet) -> bytes:
    """The toy exporter: the number of vertices of each piece's sew and cut lines, separated as its option says."""
    sep = {"space": " ", "comma": ","}[options.get("separator")]
    return sep.join(f"{len(p.sew)}{sep}{len(p.cut)}" for p in sheet.pieces).encode("ascii") + b"\n"


def _toy_reader(path: Path) -> Opened:
    """The toy reader: any .toy file holds the sphere octant, in centimetres."""
    return Opened(surface=load_example("octant"), units="cm")


@pytest.fixture
def toy_formats():
    """A .txt exporter and a .toy reader, each one registry call; removed afterwards."""
    register_exporter(".txt", _txt_writer, "outline vertex counts", needs_sheet=True, options=(SEPARATOR,))
    register_reader("toy", ".toy", _toy_reader, "toy surface")
    yield
    unregister_exporter(".txt")
    unregister_reader("toy")


def _flatten_help(capsys) -> str:
    with pytest.raises(SystemExit) as exc:
        main(["flatten", "--help"])
    assert exc.value.code == 0
    return capsys.readouterr().out


def test_toy_exporter_through_the_cli(toy_formats, tmp_path, capsys):
    out = tmp_path / "X.txt"
    assert main(["flatten", "octant", "--spacing", "0.1", "--solver", "none", "--quiet", "--export", str(out)]) == 0
    counts = out.read_text().split()
    assert len(counts) == 2 and all(int(c) > 20 for c in counts)  # sew and cut of one piece, space-separated
    assert ".txt (outline vertex counts)" in " ".join(_flatten_help(capsys).split())
    # an unknown suffix is refused before the solve, and the message lists the new format
    assert main(["flatten", "octant", "--spacing", "0.1", "--export", str(tmp_path / "p.xyz")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "'.xyz'" in err and ".txt" in err and ".dxf" in err


def test_a_toy_exporters_option_is_a_flag_and_reaches_its_writer(toy_formats, tmp_path, capsys):
    """An option declared with the exporter is a CLI flag (help from the declaration), reaches
    the writer through ExportOptions, is checked in one line, and leaves with the exporter."""
    out = tmp_path / "X.txt"
    assert main(["flatten", "octant", "--spacing", "0.1", "--solver", "none", "--quiet", "--export", str(out),
                 "--separator", "comma"]) == 0
    counts = out.read_text().strip()
    assert "," in counts and " " not in counts and all(int(c) > 3 for c in counts.split(","))
    assert "--separator {space,comma}" in _flatten_help(capsys)
    assert "what separates the toy's counts (.txt; default space)" in " ".join(_flatten_help(capsys).split())
    assert ExportOptions.from_values({"separator": "comma"}).get("separator") == "comma"
    assert ExportOptions().get("separator") == "space"
    with pytest.raises(SettingsError, match="unknown separator 'tab': use one of space, comma"):
        ExportOptions(extra={"separator": "tab"})


def test_the_built_in_export_options_are_declared_once():
    names = [o.name for o in export_options()]
    assert names == ["seam_allowance_mm", "units", "name", "dxf_variant", "paper", "obj_texture"]
    assert "separator" not in names
    with pytest.raises(SettingsError, match="no export format has an option 'separator'"):
        ExportOptions(extra={"separator": "comma"})
    with pytest.raises(SettingsError, match="seam allowance -1 mm must be a number from 0 to 500"):
        ExportOptions(seam_allowance_mm=-1)


def test_toy_reader_through_the_cli(toy_formats, tmp_path, capsys):
    path = tmp_path / "file.toy"
    path.write_text("anything")
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert str(path) in out and "area 1.570796327" in out
    assert ".toy: toy surface" in " ".join(_flatten_help(capsys).split())
    opened = open_path(path)
    assert opened.reader == "toy" and opened.units == "cm" and opened.path == path and opened.source == str(path)
    assert opened.as_project().units == "cm"


def test_dialog_filters_come_from_the_registries(toy_formats):
    assert readers.dialog_filter() == ("All supported (*.flatweave *.toml *.json *.step *.stp *.iges *.igs "
                                       "*.stl *.obj *.ply *.off *.toy);;"
                                       "flatweave project (*.flatweave);;"
                                       "flatweave job: a laminate's plies in TOML (*.toml);;"
                                       "geomdl JSON surface (*.json);;"
                                       "STEP faces (*.step *.stp);;IGES faces (*.iges *.igs);;"
                                       "STL mesh (*.stl);;OBJ mesh (*.obj);;PLY mesh (*.ply);;OFF mesh (*.off);;"
                                       "toy surface (*.toy)")
    assert readers.dialog_filter(project=False).startswith(
        "All supported (*.json *.step *.stp *.iges *.igs *.stl *.obj *.ply *.off *.toy);;")
    assert dialog_filter().split(";;")[-1] == "outline vertex counts (*.txt)"
    assert ".txt" in FORMATS and list(FORMATS)[-1] == ".txt"


def test_toy_formats_are_gone_after_the_fixture():
    assert ".txt" not in FORMATS and reader_for("a.toy") is None
    assert "*.toy" not in readers.dialog_filter() and "*.txt" not in dialog_filter()


# ---------------------------------------------------------------------- the reader registry
def test_builtin_readers_and_filter():
    assert readers.suffixes() == [PROJECT_SUFFIX, ".toml", ".json", ".step", ".stp", ".iges", ".igs",
                                  ".stl", ".obj", ".ply", ".off"]
    assert readers.dialog_filter() == ("All supported (*.flatweave *.toml *.json *.step *.stp *.iges *.igs "
                                       "*.stl *.obj *.ply *.off);;"
                                       "flatweave project (*.flatweave);;"
                                       "flatweave job: a laminate's plies in TOML (*.toml);;"
                                       "geomdl JSON surface (*.json);;"
                                       "STEP faces (*.step *.stp);;IGES faces (*.iges *.igs);;"
                                       "STL mesh (*.stl);;OBJ mesh (*.obj);;PLY mesh (*.ply);;OFF mesh (*.off)")
    assert reader_for("a" + PROJECT_SUFFIX.upper()).project and not reader_for("a.JSON").project
    assert reader_for("laminate.TOML").project  # a job file opens as a project
    assert reader_for("a.step").name == "step" and reader_for("a.IGS").name == "iges" and reader_for("a.3dm") is None


def test_example_by_name_and_by_file_has_its_spacing_and_units():
    for name in example_names():
        info = example_info(name)
        for given in (name, example_path(name)):
            o = open_path(given)
            assert isinstance(o.surface, NurbsSurface) and o.project is None
            assert (o.example, o.spacing, o.units) == (name, info["recommended_spacing"], info["units"])
            assert o.path == example_path(name) and o.source == str(example_path(name))
        p = open_path(name).as_project()
        assert (p.name, p.source, p.settings.spacing, p.units) == (name, str(example_path(name)),
                                                                   info["recommended_spacing"], "m")


def test_surface_file_and_project_file(tmp_path):
    surface = tmp_path / "bump.json"
    shutil.copy(example_path("saddle"), surface)
    o = open_path(surface)
    assert o.example is None and o.spacing is None and o.units is None and o.reader == "geomdl-json"
    p, q = o.as_project(), new_project(o.surface, "bump", str(surface))
    assert (p.name, p.source, p.units, p.settings.spacing) == (q.name, q.source, q.units, q.settings.spacing)
    project_file = tmp_path / ("piece" + PROJECT_SUFFIX)
    save_project(new_project(o.surface, "piece", str(surface), 0.2, "cm"), project_file)
    o = open_path(project_file)
    assert isinstance(o.project, Project) and o.surface is o.project.surface and o.as_project() is o.project
    assert o.name == "piece" and o.path == project_file and o.reader == "flatweave-project"


@pytest.mark.parametrize("name, words", [
    ("teapot", ["'teapot' is neither a file nor a bundled example", "octant"]),
    ("piece.3dm", ["piece.3dm", "'.3dm'", ".flatweave", ".json", ".step"]),
    ("piece.step", ["piece.step", "no such file"]),
    ("nowhere.json", ["nowhere.json", "no such file"]),  # worded as every door words it (flatweave.files)
])
def test_open_errors_are_one_line(tmp_path, name, words):
    with pytest.raises(FlatweaveError) as exc:
        open_path(tmp_path / name if "." in name else name)
    text = str(exc.value)
    assert "\n" not in text and all(w in text for w in words), text


def test_commands_on_surfaces_refuse_a_project(tmp_path, capsys):
    path = tmp_path / ("p" + PROJECT_SUFFIX)
    path.write_text("not even read")
    with pytest.raises(SettingsError, match="is a flatweave project, not a surface"):
        open_path(path, surface_only=True)
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("flatweave: error:") and err.count("\n") == 1 and ".json" in err


def test_registration_is_checked():
    with pytest.raises(ValueError, match="already read"):
        register_reader("other-json", ".JSON", _toy_reader, "another")
    with pytest.raises(ValueError, match="already registered"):
        register_reader("geomdl-json", ".g", _toy_reader, "another")
    with pytest.raises(ValueError, match="suffix"):
        register_reader("bad", "json", _toy_reader, "no dot")
    with pytest.raises(ValueError, match="already have an exporter"):
        register_exporter(".DXF", _txt_writer, "again", needs_sheet=True)
    assert readers.suffixes() == [PROJECT_SUFFIX, ".toml", ".json", ".step", ".stp", ".iges", ".igs",
                                  ".stl", ".obj", ".ply", ".off"]
    assert "bad" not in [r.name for r in readers.readers()]


def test_a_reader_must_return_a_surface_or_opened(tmp_path):
    register_reader("broken", ".broken", lambda path: {"not": "a surface"}, "broken")
    try:
        (tmp_path / "a.broken").write_text("x")
        with pytest.raises(TypeError, match="broken"):
            open_path(tmp_path / "a.broken")
    finally:
        unregister_reader("broken")


# ---------------------------------------------------------------------- the exporter registry
def test_formats_is_a_read_only_view_of_the_registry():
    assert list(FORMATS) == [".dxf", ".svg", ".pdf", ".vtp", ".obj", ".csv"]
    assert FORMATS[".dxf"] == exporter_for(".DXF").description
    with pytest.raises(TypeError):
        FORMATS[".x"] = "y"  # type: ignore[index]
    assert [e.needs_sheet for e in map(exporter_for, FORMATS)] == [True, True, True, False, False, False]
    assert dialog_filter().split(";;")[0] == "DXF, ASTM D6673 / AAMA (R12) or layered R2000, mm (*.dxf)"
    with pytest.raises(SettingsError, match="unknown export format '.xyz'; use one of .dxf, .svg"):
        export_bytes(None, ".xyz", ExportOptions())


# ---------------------------------------------------------------------- packaging
@pytest.mark.slow
def test_wheel_installs_one_package_with_its_examples(tmp_path):
    """A built wheel installs one top-level package, flatweave (the folders core/
    and app/ as flatweave and flatweave.app, nothing named core or app), holds
    every example surface as package data, and runs from the installed files:
    the examples found with importlib.resources, ``python -m flatweave`` flattens."""
    src = tmp_path / "src"
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    for name in ("core", "app", "resources"):
        shutil.copytree(REPO / name, src / name, ignore=ignore)
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(REPO / name, src / name)
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "--no-cache-dir",
                           "--wheel-dir", str(tmp_path / "dist"), str(src)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    (wheel,) = (tmp_path / "dist").glob("flatweave-*.whl")
    index = json.loads((REPO / "resources" / "surfaces" / "index.json").read_text(encoding="utf-8"))
    with zipfile.ZipFile(wheel) as zf:
        names = set(zf.namelist())
        want = {"flatweave/examples_data/index.json"} | {f"flatweave/examples_data/{e['file']}"
                                                         for e in index["examples"]}
        want |= {"flatweave/__init__.py", "flatweave/app/main.py", "flatweave/method/pipeline.py",
                 "flatweave/example_jobs/dome-laminate.toml"}
        assert want <= names, sorted(want - names)
        tops = {n.split("/")[0] for n in names if not n.split("/")[0].endswith(".dist-info")}
        assert tops == {"flatweave"}, tops  # no generic top-level name: core, app, resources
        zf.extractall(tmp_path / "site")
    script = ("import sys; sys.path.insert(0, sys.argv[1]); import flatweave.reading.examples as e; "
              "print(e.surfaces_dir()); print(e.load_example('garment').shape)")
    run = subprocess.run([sys.executable, "-c", script, str(tmp_path / "site")], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    where, shape = run.stdout.splitlines()
    assert Path(where) == tmp_path / "site" / "flatweave" / "examples_data" and shape == "(7, 8)"
    env = {**os.environ, "PYTHONPATH": str(tmp_path / "site")}
    cli = subprocess.run([sys.executable, "-m", "flatweave", "flatten", "octant", "--spacing", "0.1",
                          "--out", "r.json"], cwd=tmp_path,
                         env=env, capture_output=True, text=True, timeout=300)
    assert cli.returncode == 0, cli.stderr
    assert "converged" in cli.stderr + cli.stdout and (tmp_path / "r.json").is_file()
    # the bundled example job runs with no other file, its project written here
    job = subprocess.run([sys.executable, "-m", "flatweave", "solve", "dome-laminate", "--piece", "P24", "--quiet"],
                         cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert job.returncode == 0, job.stderr
    assert (tmp_path / "dome-laminate.flatweave").is_file()
