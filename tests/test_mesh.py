"""Spring mesh topology (paper 2.1) and materials."""

import numpy as np
import pytest

from flatweave.errors import SettingsError
from flatweave.method.lattice import DIAG, MATERIALS, WARP, WEFT, build_mesh, parse_material


def rect(R, C):
    i, j = np.meshgrid(np.arange(R), np.arange(C), indexing="ij")
    return np.column_stack([i.ravel(), j.ravel()])


def test_full_rectangle_has_every_spring():
    R, C = 5, 7
    m = build_mesh(rect(R, C), 0.1, 0.2, MATERIALS["woven"])
    assert np.sum(m.kind == WEFT) == R * (C - 1)
    assert np.sum(m.kind == WARP) == (R - 1) * C
    assert np.sum(m.kind == DIAG) == 2 * (R - 1) * (C - 1)
    assert len(m.cells) == (R - 1) * (C - 1)
    # rest lengths and constants by kind
    assert np.allclose(m.rest[m.kind == WEFT], 0.1)
    assert np.allclose(m.rest[m.kind == WARP], 0.2)
    assert np.allclose(m.rest[m.kind == DIAG], np.hypot(0.1, 0.2))
    assert np.allclose(m.k[m.kind == DIAG], 1.0) and np.allclose(m.k[m.kind != DIAG], 500.0)
    # springs join lattice neighbours only
    d = np.abs(m.ij[m.ends[:, 0]] - m.ij[m.ends[:, 1]])
    assert np.all(d.max(axis=1) == 1)
    # interior nodes have 8 springs
    deg = m.degree()
    interior = (m.ij[:, 0] > 0) & (m.ij[:, 0] < R - 1) & (m.ij[:, 1] > 0) & (m.ij[:, 1] < C - 1)
    assert np.all(deg[interior] == 8)
    assert not m.boundary_nodes()[interior].any() and m.boundary_nodes()[~interior].all()


def test_diagonal_needs_a_third_corner():
    # an L of three nodes carries one diagonal; two diagonal-only nodes carry none
    L = np.array([[0, 0], [0, 1], [1, 0]])
    m = build_mesh(L, 1, 1, MATERIALS["isotropic"])
    assert sorted(m.kind.tolist()) == [WEFT, WARP, DIAG]
    assert len(m.cells) == 0
    m2 = build_mesh(np.array([[0, 0], [1, 1]]), 1, 1, MATERIALS["isotropic"])
    assert m2.n_springs == 0


def test_lattice_xy_is_relaxed_grid():
    m = build_mesh(np.array([[0, 0], [2, 3], [-1, 1]]), 0.5, 0.25, MATERIALS["woven"])
    assert np.allclose(m.lattice_xy(), [[0, 0], [1.5, 0.5], [0.5, -0.25]])


def test_keep_removes_springs_and_cells():
    m = build_mesh(rect(3, 3), 1, 1, MATERIALS["woven"], keep=lambda ends, kind: kind != WEFT)
    assert not np.any(m.kind == WEFT) and len(m.cells) == 0


def test_a_cell_is_kept_exactly_when_its_four_thread_edges_are():
    """Random springs cut from a lattice with a hole: the cells kept are those whose four weft and
    warp edges (either way round) are still springs, whatever the diagonals."""
    ij = rect(9, 11)
    ij = ij[~((ij[:, 0] == 4) & (ij[:, 1] == 5))]
    rng = np.random.default_rng(3)
    for share in (0.0, 0.05, 0.3, 1.0):
        cut = rng.random(10_000) < share
        m = build_mesh(ij, 1, 1, MATERIALS["woven"], keep=lambda ends, kind: ~cut[:len(ends)])
        full = build_mesh(ij, 1, 1, MATERIALS["woven"])
        pairs = {frozenset(e) for e, k in zip(m.ends.tolist(), m.kind) if k != DIAG}
        want = [c for c in full.cells.tolist()
                if all(frozenset((c[s], c[t])) in pairs for s, t in ((0, 1), (1, 2), (3, 2), (0, 3)))]
        assert m.cells.tolist() == want
        assert (share == 0.0) == (len(want) == len(full.cells)) and (share < 1.0) == (len(want) > 0)


@pytest.mark.parametrize("text, ratio", [("woven", "500:500:1"), ("Isotropic", "100:100:50"),
                                         ("paper-isotropic", "100:100:100"),
                                         ("10:20:3", "10:20:3")])
def test_parse_material(text, ratio):
    assert parse_material(text).ratio == ratio


@pytest.mark.parametrize("text", ["silk", "1:2", "1:0:1", "a:b:c", "-1:1:1"])
def test_parse_material_rejects(text):
    with pytest.raises(SettingsError):
        parse_material(text)
