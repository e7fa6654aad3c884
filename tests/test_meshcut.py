"""A panel cut from any mesh along a loop drawn on it (flatweave.geometry.meshcut):
the outline is the drawn loop (triangles split, not the nearest edges), holes
stay holes, the inside of an open mesh is the side away from its boundary, and
bad loops are one line."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
import trimesh

from flatweave.errors import SettingsError
from flatweave.geometry.meshcut import closest_on_mesh, cut_mesh, drawn_loop_on_mesh, project_to_mesh
from flatweave.geometry.meshfit import boundary_loops, lscm, map_distortion

T = np.linspace(0.0, 2.0 * np.pi, 240, endpoint=False)


def sphere(cut_below: float | None = None, subdivisions: int = 5):
    """The unit icosphere; with ``cut_below``, only its triangles above that height (an open dome)."""
    m = trimesh.creation.icosphere(subdivisions=subdivisions)
    V, F = np.asarray(m.vertices), np.asarray(m.faces)
    if cut_below is not None:
        F = F[V[F].mean(axis=1)[:, 2] > cut_below]
        used = np.unique(F)
        V, F = V[used], np.searchsorted(used, F)
    return V, F


def circle(a: float) -> np.ndarray:
    """The circle at angle ``a`` from the north pole of the unit sphere."""
    return np.column_stack([np.sin(a) * np.cos(T), np.sin(a) * np.sin(T), np.full_like(T, np.cos(a))])


def area(V, F) -> float:
    return float(0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1).sum())


def polar(P) -> np.ndarray:
    return np.arctan2(np.linalg.norm(P[:, :2], axis=1), P[:, 2])


def test_closest_on_mesh_is_the_brute_force_nearest():
    V, F = sphere(subdivisions=2)
    rng = np.random.default_rng(3)
    P = rng.normal(size=(200, 3)) * 0.7
    tri, w, xyz, dist = closest_on_mesh(V, F, P)
    # brute force over every triangle: the nearest of 300 sample points of each (about 0.02 apart)
    s = rng.dirichlet(np.ones(3), size=300)
    samples = np.einsum("sj,mjd->msd", s, V[F]).reshape(-1, 3)
    brute = np.array([np.min(np.linalg.norm(samples - p, axis=1)) for p in P])
    assert np.all(dist <= brute + 1e-12) and np.all(brute - dist < 0.05)  # never farther, and as near
    np.testing.assert_allclose(np.einsum("kj,kjd->kd", w, V[F[tri]]), xyz, atol=1e-12)
    assert np.all(w >= -1e-12) and np.allclose(w.sum(axis=1), 1.0)


def test_a_panel_of_an_open_dome_has_the_drawn_outline():
    V, F = sphere(cut_below=-0.2)
    for a in (0.5, 1.3):  # 1.3: the inside is larger than the rest, still the side away from the dome's rim
        Vc, Fc = cut_mesh(V, F, circle(a), "dome")
        loops = boundary_loops(Fc)
        assert len(loops) == 1
        # the outline is the circle itself, put on the facets (edges 0.03 long: their sagitta 1e-4 moves it)
        np.testing.assert_allclose(polar(Vc[loops[0]]), a, atol=5e-4)
        cap = 2 * np.pi * (1 - np.cos(a))
        assert area(Vc, Fc) == pytest.approx(cap, rel=1.5e-3)  # the icosphere's facets are 0.05 % short
        _, _, _, dist = closest_on_mesh(V, F, Vc)
        assert dist.max() < 1e-9  # every new point lies on the mesh
        assert polar(Vc).max() <= a + 5e-4


def test_the_piece_keeps_the_mesh_winding():
    V, F = sphere(cut_below=-0.2)
    Vc, Fc = cut_mesh(V, F, circle(0.8), "dome")
    n = np.cross(Vc[Fc[:, 1]] - Vc[Fc[:, 0]], Vc[Fc[:, 2]] - Vc[Fc[:, 0]])
    centre = Vc[Fc].mean(axis=1)
    big = np.linalg.norm(n, axis=1) > 1e-12
    assert np.all(np.einsum("ij,ij->i", n[big], centre[big]) > 0)  # outward, as the icosphere's


def test_a_hole_drawn_inside_stays_a_hole_and_a_closed_mesh_keeps_the_smaller_side():
    V, F = sphere()
    Vc, Fc = cut_mesh(V, F, circle(0.9), "ball", holes3d=[circle(0.3)])
    loops = boundary_loops(Fc)
    assert len(loops) == 2
    assert area(Vc, Fc) == pytest.approx(2 * np.pi * (np.cos(0.3) - np.cos(0.9)), rel=1.5e-3)
    Vc, Fc = cut_mesh(V, F, circle(2.0), "ball")  # the south cap is the smaller side
    assert Vc[:, 2].max() == pytest.approx(np.cos(2.0), abs=5e-4)
    assert area(Vc, Fc) == pytest.approx(2 * np.pi * (1 + np.cos(2.0)), rel=1.5e-3)


def test_a_panel_is_flatter_than_the_whole():
    V, F = sphere(cut_below=-0.2)
    Vc, Fc = cut_mesh(V, F, circle(0.6), "dome")
    whole, panel = map_distortion(V, F, lscm(V, F)), map_distortion(Vc, Fc, lscm(Vc, Fc))
    assert whole > 0.3 and panel < 0.1


@pytest.mark.parametrize("loop, holes, says", [
    (circle(0.5) * 3, (), "misses it"),
    (np.r_[circle(0.5)[:120], circle(0.5)[:120][:, [1, 0, 2]]], (), "crosses itself"),
    (circle(0.5)[:2], (), "3 or more"),
    ("not points", (), "[x, y, z] points"),
    (circle(0.5), [circle(0.9)], "crosses itself or a hole leaves it"),
])
def test_bad_loops_are_one_line(loop, holes, says):
    V, F = sphere(subdivisions=4)
    with pytest.raises(SettingsError, match=None) as err:
        cut_mesh(V, F, loop, "ball", holes3d=holes)
    assert says in str(err.value) and "\n" not in str(err.value)


def test_a_loop_round_a_torus_tube_does_not_cut_it():
    m = trimesh.creation.torus(major_radius=1.0, minor_radius=0.3, major_sections=64, minor_sections=32)
    ring = np.column_stack([1.0 + 0.3 * np.cos(T), np.zeros_like(T), 0.3 * np.sin(T)])  # round the tube
    with pytest.raises(SettingsError, match="does not cut it in two"):
        cut_mesh(np.asarray(m.vertices), np.asarray(m.faces), ring, "torus")


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "flatweave", *map(str, args)], capture_output=True, text=True,
                          timeout=600)


@pytest.mark.slow
def test_the_cli_warns_on_a_whole_dome_and_cuts_a_panel_with_a_hole(tmp_path):
    V, F = sphere(cut_below=-0.2)
    path = tmp_path / "dome.stl"
    trimesh.Trimesh(V * 100.0, F, process=False).export(path)
    out = tmp_path / "r.json"
    p = _cli("flatten", path, "--spacing", "8", "--out", out, "--quiet")
    assert p.returncode == 0
    first = p.stderr.splitlines()[0]
    assert first.startswith("flatweave: warning: dome.stl is far from developable") and "--region" in first
    region = tmp_path / "panel.json"
    region.write_text(json.dumps({"loop3d": (100 * circle(0.7)).tolist(), "holes3d": [(100 * circle(0.2)).tolist()]}))
    p = _cli("flatten", path, "--spacing", "5", "--region", region, "--out", out, "--quiet")
    assert p.returncode == 0 and "far from developable" not in p.stderr, p.stderr
    m = json.loads(out.read_text())["metrics"]
    assert m["area_3d"] == pytest.approx(2 * np.pi * 1e4 * (np.cos(0.2) - np.cos(0.7)), rel=5e-3)
    assert m["boundary_error_pct"] < 5.0


def _first_hits_brute(V, F, P, d):
    """Every line P + t d against every triangle in 3D (Moeller-Trumbore), the hit of smallest t."""
    A, B, C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    out = np.full((len(P), 3), np.nan)
    for k, p in enumerate(P):
        e1, e2 = B - A, C - A
        h = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, h)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.einsum("ij,ij->i", p - A, h) / det
            q = np.cross(p - A, e1)
            t = (q @ d) / det
            tt = np.einsum("ij,ij->i", e2, q) / det
        ok = (np.abs(det) > 1e-15) & (s >= 0) & (t >= 0) & (s + t <= 1)
        if ok.any():
            out[k] = p + tt[ok].min() * d
    return out


def test_points_seen_along_a_view_land_on_the_first_triangle_the_line_meets():
    V, F = sphere(subdivisions=3)
    rng = np.random.default_rng(5)
    d = np.array([0.3, -0.2, -1.0])
    d /= np.linalg.norm(d)
    P = rng.uniform(-1.3, 1.3, size=(150, 3))  # some lines miss the ball, some start inside it
    xyz, hit = project_to_mesh(V, F, P, d)
    brute = _first_hits_brute(V, F, P, d)
    assert hit.sum() > 50 and (~hit).sum() > 5
    np.testing.assert_array_equal(hit, np.isfinite(brute[:, 0]))
    np.testing.assert_allclose(xyz[hit], brute[hit], atol=1e-9)


def test_a_region_drawn_along_a_view_is_cut_along_the_projection_of_its_sides():
    """A square drawn above a dome, seen from above: the panel's outline is the square's
    projection (its sides' points keep their x, y), not the chords between its corners on the dome."""
    V, F = sphere(cut_below=-0.2)
    sq = np.array([[-0.5, -0.5, 3.0], [0.5, -0.5, 3.0], [0.5, 0.5, 3.0], [-0.5, 0.5, 3.0]])
    loop = drawn_loop_on_mesh(V, F, sq, [0, 0, -1], "dome")
    Vc, Fc = cut_mesh(V, F, loop, "dome")
    rim = Vc[boundary_loops(Fc)[0]]
    # every rim point on the square's outline in x, y, to a hundredth of an edge (between two samples the
    # cut is straight in the piece's flat map, which bends where the facets do), and on the dome's top
    edge = np.median(np.linalg.norm(V[F[:, 1]] - V[F[:, 0]], axis=1))
    off = np.minimum(np.abs(np.abs(rim[:, 0]) - 0.5), np.abs(np.abs(rim[:, 1]) - 0.5))
    assert off.max() < 0.01 * edge and np.abs(rim[:, :2]).max() < 0.5 + 0.01 * edge and rim[:, 2].min() > 0.6
    assert len(rim) > 4 * 8  # the sides' samples, not four chords
    with pytest.raises(SettingsError, match="misses it: point 2"):
        drawn_loop_on_mesh(V, F, [[0, 0, 3], [5, 5, 3], [0, 0.5, 3]], [0, 0, -1], "dome")


def _finned_sheet():
    """A flat 20 x 20 grid of squares with one extra triangle on an interior edge near a corner (a
    fin: the edge belongs to three triangles, as scans have a few)."""
    ij = np.array([(i, j) for i in range(21) for j in range(21)], dtype=float)
    V = np.column_stack([ij, np.zeros(len(ij))])
    F = []
    for i in range(20):
        for j in range(20):
            a, b, c, e = 21 * i + j, 21 * (i + 1) + j, 21 * (i + 1) + j + 1, 21 * i + j + 1
            F += [(a, b, c), (a, c, e)]
    V = np.vstack([V, [[2.5, 2.5, 1.0]]])
    F.append((21 * 2 + 2, 21 * 3 + 3, len(V) - 1))  # on the diagonal edge of square (2, 2)
    return V, np.array(F)


def test_a_panel_away_from_a_non_manifold_edge_is_cut_and_one_reaching_it_is_refused(tmp_path):
    from flatweave.reading.meshes import open_mesh

    V, F = _finned_sheet()
    path = tmp_path / "finned.obj"
    trimesh.Trimesh(V, F, process=False).export(path)
    opened = open_mesh(path)
    assert opened.surface is None and "non-manifold" in opened.mesh.needs_region  # not covered whole
    t = np.linspace(0, 2 * np.pi, 60, endpoint=False)
    far = np.column_stack([12 + 4 * np.cos(t), 12 + 4 * np.sin(t), np.zeros_like(t)])
    piece = opened.mesh.cut(far)
    assert any(r.startswith("set aside 3 triangles at 1 non-manifold edges") for r in piece.fit.repairs)
    assert piece.fit.max_deviation < 1e-4 * piece.fit.size  # a flat panel, fitted as flat
    near = np.column_stack([3 + 2 * np.cos(t), 3 + 2 * np.sin(t), np.zeros_like(t)])
    with pytest.raises(SettingsError) as err:
        opened.mesh.cut(near)
    assert "encloses or touches a non-manifold part" in str(err.value) and "\n" not in str(err.value)


@pytest.mark.slow
def test_the_cli_cuts_a_region_drawn_as_points_seen_along_a_view(tmp_path):
    V, F = sphere(cut_below=-0.2)
    path = tmp_path / "dome.stl"
    trimesh.Trimesh(V * 100.0, F, process=False).export(path)
    t = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    a = 0.7
    drawn = np.column_stack([100 * np.sin(a) * np.cos(t), 100 * np.sin(a) * np.sin(t), np.full_like(t, 500.0)])
    region = tmp_path / "drawn.json"
    region.write_text(json.dumps({"points": drawn.tolist(), "view_direction": [0, 0, -1]}))
    out = tmp_path / "r.json"
    p = _cli("flatten", path, "--spacing", "5", "--region", region, "--out", out, "--quiet")
    assert p.returncode == 0, p.stderr
    m = json.loads(out.read_text())["metrics"]
    # the 24-gon's projection: its cap area lies between the inscribed and the circumscribed circle's
    inner = 2 * np.pi * 1e4 * (1 - np.cos(np.arcsin(np.sin(a) * np.cos(np.pi / 24))))
    assert inner * 0.995 < m["area_3d"] < 2 * np.pi * 1e4 * (1 - np.cos(a)) * 1.005
    region.write_text(json.dumps({"points": drawn.tolist()}))
    p = _cli("flatten", path, "--spacing", "5", "--region", region, "--out", out, "--quiet")
    assert p.returncode == 2 and "view_direction" in p.stderr and p.stderr.count("\n") == 1


@pytest.mark.slow
@pytest.mark.parametrize("vertex, says", [("1e308 1e308 0", "coordinates up to 1e+308"),
                                          ("nan 1 0", "1 vertices with NaN")])
def test_a_region_drawn_on_a_broken_mesh_is_refused_in_one_line_and_nothing_else(tmp_path, vertex, says):
    path = tmp_path / "broken.obj"
    path.write_text(f"v 0 0 0\nv 1 0 0\nv 0 1 0\nv {vertex}\nf 1 2 3\nf 2 4 3\n")
    for spec in ({"points": [[0, 0, 1], [1, 0, 1], [0, 1, 1]], "view_direction": [0, 0, -1]},
                 {"loop3d": [[0, 0, 0], [1, 0, 0], [0, 1, 0]]}):
        region = tmp_path / "region.json"
        region.write_text(json.dumps(spec))
        p = _cli("flatten", path, "--spacing", "1", "--region", region, "--out", tmp_path / "r.json")
        assert p.returncode == 2 and p.stderr.count("\n") == 1 and says in p.stderr, p.stderr
