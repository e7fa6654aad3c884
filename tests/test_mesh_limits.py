"""The mesh limits are honest (issue 45, item 5): a mesh of up to MAX_TRIANGLES is read and
described, one piece of up to MAX_FIT_TRIANGLES is mapped and fitted, a larger piece is one
line asking for a panel (or a smaller one). The limit is lowered in the tests so that the
meshes stay small; benchmarks/mesh_limits.py times the real ones."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

from flatweave.cli import main
from flatweave.geometry import meshfit
from flatweave.geometry.meshfit import clean_mesh, edge_table, split_pinched, used_vertices
from flatweave.reading.meshes import open_mesh
from tests.helpers import wavy_sheet


def sheet(n: int) -> tuple[np.ndarray, np.ndarray]:
    """A wavy open square sheet of 2 n^2 triangles, 1 unit across."""
    return wavy_sheet(n, amp=0.1)


@pytest.fixture
def small_limit(monkeypatch):
    monkeypatch.setattr(meshfit, "MAX_FIT_TRIANGLES", 300)


def test_a_mesh_over_the_fit_limit_is_described_and_asks_for_a_panel(tmp_path, capsys, small_limit):
    V, F = sheet(14)  # 392 triangles
    path = tmp_path / "sheet.stl"
    trimesh.Trimesh(V, F, process=False).export(path)
    opened = open_mesh(path)
    assert opened.surface is None and "392 triangles, more than the 300" in opened.mesh.needs_region

    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "mesh of 225 vertices and 392 triangles" in out and "1 boundary loop, genus 0" in out
    assert out.strip().splitlines()[-1] == ("sheet.stl has 392 triangles, more than the 300 one piece is fitted "
                                            "from: draw a panel on it (--region), or decimate the mesh")

    code = main(["flatten", str(path), "--spacing", "0.1", "--units", "m", "--out", str(tmp_path / "r.json"),
                 "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "more than the 300 one piece is fitted from" in err[0]
    assert not (tmp_path / "r.json").exists()


def _loop(r: float, n: int = 64) -> list:
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    x, y = 0.5 + r * np.cos(t), 0.5 + r * np.sin(t)
    return np.stack([x, y, 0.1 * np.sin(3 * x) * np.cos(2 * y)], axis=1).tolist()


def test_a_panel_under_the_limit_is_fitted_and_one_over_it_is_one_line(tmp_path, capsys, small_limit):
    V, F = sheet(14)
    path = tmp_path / "sheet.stl"
    trimesh.Trimesh(V, F, process=False).export(path)
    small, large = tmp_path / "small.json", tmp_path / "large.json"
    small.write_text(json.dumps({"loop3d": _loop(0.25)}))  # about 0.2 of the 1.0 square: ~80 triangles
    large.write_text(json.dumps({"loop3d": _loop(0.45)}))  # about 0.64: over 300 once the rim is split
    out = tmp_path / "r.json"
    assert main(["flatten", str(path), "--region", str(small), "--spacing", "0.05", "--units", "m", "--out", str(out),
                 "--quiet"]) == 0
    fit = json.loads(out.read_text())["metrics"]
    assert fit["area_3d"] == pytest.approx(np.pi * 0.25 ** 2, rel=0.05)  # a gently waved disc

    out.unlink()
    code = main(["flatten", str(path), "--region", str(large), "--spacing", "0.05", "--units", "m",
                 "--out", str(out), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert err[0].startswith("flatweave: error: the piece cut from sheet.stl has ") and "draw a smaller panel" in err[0]
    assert not out.exists()


def test_used_vertices_is_numpys_unique():
    rng = np.random.default_rng(3)
    F = rng.integers(0, 1000, size=(500, 3)) * 7
    assert np.array_equal(used_vertices(F), np.unique(F))
    assert np.array_equal(used_vertices(F, n=7001), np.unique(F))
    assert used_vertices(np.zeros((0, 3), dtype=np.int64)).size == 0


def test_clean_mesh_winds_and_splits_as_from_a_fresh_edge_table():
    """clean_mesh hands its edge table on to the winding and the split of pinched vertices (the
    re-wound rows' directed edges permuted, not recomputed): the same triangles, vertices and
    split as each step computing its own."""
    V, F = sheet(6)
    # two corners of the sheet made one vertex: one part, two fans of triangles touching at a point
    F_all = np.where(F == 6 * 7, 0, F)
    rng = np.random.default_rng(5)
    flip = rng.random(len(F_all)) < 0.4
    F_all[flip] = F_all[flip][:, ::-1]  # a winding to repair
    Vc, Fc, repairs = clean_mesh(V, F_all)
    assert any(r.startswith("re-wound") for r in repairs)
    assert "split 1 vertices where separate fans of triangles touched" in repairs

    # each step on its own: the winding consistent across every interior edge, and the split from scratch
    E = np.stack([Fc, np.roll(Fc, -1, axis=1)], axis=2).reshape(-1, 2)
    _, inv, count = edge_table(Fc)
    order = np.argsort(inv, kind="stable")
    pairs = order[count[inv[order]] == 2].reshape(-1, 2)
    assert np.all(E[pairs[:, 0], 0] == E[pairs[:, 1], 1])  # each interior edge run in opposite senses
    Vs, Fs, n_split = split_pinched(Vc, Fc)
    assert n_split == 0 and np.array_equal(Fs, Fc) and np.array_equal(Vs, Vc)  # nothing left to split
    assert len(Vc) == len(V)  # the unused corner dropped, the shared one split again into two
