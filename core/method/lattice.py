"""The spring mesh of the woven fabric model (paper section 2.1).

Nodes sit at lattice positions M[i, j] (row i, column j; the drape's seed is
M[0, 0] and indices may be negative). The springs are derived from which
lattice positions hold a node:

* weft springs join M[i, j] and M[i, j+1] (along a row),
* warp springs join M[i, j] and M[i+1, j] (along a column),
* diagonal springs join the opposite corners of a cell; a diagonal is present
  when both its ends exist and at least one of the cell's other two corners
  does, i.e. every triangle of the lattice carries its diagonal.

Everything is stored as arrays (endpoints, kind, rest length, constant); the
topology depends only on the lattice, never on positions, so it is built once
per population and cached by the caller.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from flatweave.errors import SettingsError
from flatweave.geometry.numerics import nearest_segments

__all__ = ["Material", "MATERIALS", "parse_material", "SpringMesh", "build_mesh", "only_springs",
           "arc_over_chord", "bent", "ease_factor", "BEND_SINE_MAX", "WEFT", "WARP", "DIAG", "KIND_NAMES"]

WEFT, WARP, DIAG = 0, 1, 2
KIND_NAMES = ("weft", "warp", "diag")


@dataclass(frozen=True)
class Material:
    """Spring constants of the weft, warp and diagonal springs, and the
    cloth's shear warning and lock angles (degrees): beyond the warning angle
    the cloth shears visibly, beyond the lock angle it wrinkles instead. The
    angles judge a result (metrics, warnings, labels); they do not enter the
    energy."""

    name: str
    k_weft: float
    k_warp: float
    k_diag: float
    warn_deg: float = 15.0
    lock_deg: float = 30.0

    def constants(self) -> np.ndarray:
        """(3,) constants indexed by spring kind."""
        return np.array([self.k_weft, self.k_warp, self.k_diag], dtype=float)

    def to_dict(self) -> dict:
        """The material as a JSON object (project and result files)."""
        return {"name": self.name, "k_weft": self.k_weft, "k_warp": self.k_warp, "k_diag": self.k_diag,
                "warn_deg": self.warn_deg, "lock_deg": self.lock_deg}

    def same_constants(self, other: "Material") -> bool:
        """Equal spring constants (names and angles aside)."""
        return (self.k_weft, self.k_warp, self.k_diag) == (other.k_weft, other.k_warp, other.k_diag)

    @property
    def ratio(self) -> str:
        return f"{self.k_weft:g}:{self.k_warp:g}:{self.k_diag:g}"


# A square lattice with diagonals, energy k/2 (l - r)^2 per spring, has plane
# stiffnesses C11 = k_a + k_d, C12 = C66 = k_d; it is isotropic (C66 = (C11 - C12) / 2)
# only for k_d = k_a / 2. The paper's 100:100:100 is twice too stiff in shear; its
# Table 1 uses it, so it stays as "paper-isotropic"
# (docs/decisions/0026-materials-isotropic-preset-and-shear-angles.md).
MATERIALS = {
    "isotropic": Material("isotropic", 100.0, 100.0, 50.0),
    "paper-isotropic": Material("paper-isotropic", 100.0, 100.0, 100.0),
    "woven": Material("woven", 500.0, 500.0, 1.0, warn_deg=15.0, lock_deg=30.0),
}


def parse_material(text: str) -> Material:
    """A preset name (``woven``, ``isotropic``, ``paper-isotropic``) or a ratio ``WEFT:WARP:DIAG``."""
    key = text.strip().lower()
    if key in MATERIALS:
        return MATERIALS[key]
    parts = key.split(":")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) != 3:
        raise SettingsError(
            f"material {text!r} is neither a preset ({', '.join(MATERIALS)}) nor a ratio WEFT:WARP:DIAG")
    if not all(np.isfinite(values)) or min(values) <= 0:
        raise SettingsError(f"material {text!r}: spring constants must be positive numbers")
    return Material(f"custom {key}", *values)


@dataclass(frozen=True)
class SpringMesh:
    """Topology and rest state of a spring mesh.

    ij : (n, 2) int, lattice row and column of every node
    ends : (m, 2) int, node indices of every spring
    kind : (m,) int8, WEFT, WARP or DIAG
    rest : (m,) float, rest lengths
    k : (m,) float, spring constants
    cells : (c, 4) int, lattice cells whose four corners exist and whose four
        edges are springs, corners ordered (i, j), (i, j+1), (i+1, j+1), (i+1, j)
    r_weft, r_warp : float, rest lengths of weft and warp springs
    material : Material
    ease : ((line (k, 3), amount, band), ...): the springs near each polyline ``line`` on the surface
        rest longer by ``amount`` (shorter when negative), in full along the line and fading to none
        at ``band`` from it, in proportion to cos^2 of their angle with it (:func:`ease_factor`):
        what a seam whose two sides are matched in length asks of each panel (issue 42); () for none
    """

    ij: np.ndarray
    ends: np.ndarray
    kind: np.ndarray
    rest: np.ndarray
    k: np.ndarray
    cells: np.ndarray
    r_weft: float
    r_warp: float
    material: Material
    ease: tuple = ()

    @property
    def n_nodes(self) -> int:
        return int(self.ij.shape[0])

    @property
    def n_springs(self) -> int:
        return int(self.ends.shape[0])

    def thread_rest(self) -> np.ndarray:
        """(m,) the threads' own lengths between nodes: r_weft, r_warp or the cell's
        diagonal by kind (the rest lengths of arcs on the surface; ``rest`` holds
        the chords' after :func:`bent`)."""
        r_diag = float(np.hypot(self.r_weft, self.r_warp))
        return np.array([self.r_weft, self.r_warp, r_diag])[self.kind]

    def lattice_xy(self) -> np.ndarray:
        """(n, 2) relaxed 2D positions: M[i, j] at (j r_weft, i r_warp)."""
        return np.column_stack([self.ij[:, 1] * self.r_weft, self.ij[:, 0] * self.r_warp]).astype(float)

    def degree(self) -> np.ndarray:
        """(n,) number of springs at every node."""
        return np.bincount(self.ends.ravel(), minlength=self.n_nodes)

    def boundary_nodes(self) -> np.ndarray:
        """(n,) bool: nodes missing one of their four weft/warp neighbours."""
        thread = self.kind != DIAG
        deg = np.bincount(self.ends[thread].ravel(), minlength=self.n_nodes)
        return deg < 4


# Where the normals turn by more than 60 degrees across one spring (sine of half the turn 0.5)
# the mesh is folded, not bent: a circle through its ends says nothing then, and the arc is
# taken as that of a 60-degree turn (4.7 % longer than its chord).
BEND_SINE_MAX = 0.5


def arc_over_chord(d: np.ndarray, na: np.ndarray, nb: np.ndarray) -> np.ndarray:
    """(m,) the ratio arc / chord of the surface curves under chords ``d`` (m, 3)
    whose ends have unit normals ``na``, ``nb`` (m, 3).

    The curve is taken as the circle in the normal section along the chord:
    its normals turn by 2 asin(x), x = |(nb - na) . t| / 2 with t the chord's
    direction, so arc / chord = asin(x) / x (exact on a circle; on any curve
    of the surface to the change of its curvature along the chord). A missing
    normal (NaN, a pole) gives 1."""
    d = np.asarray(d, dtype=float)
    length = np.linalg.norm(d, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        x = 0.5 * np.abs(np.einsum("ij,ij->i", np.asarray(nb) - np.asarray(na), d)) / length
    x = np.minimum(np.where(np.isfinite(x), x, 0.0), BEND_SINE_MAX)
    small = x < 1e-3  # asin(x)/x by its series where the quotient loses digits
    xs = np.where(small, 1.0, x)
    return np.where(small, 1.0 + x * x / 6.0 + 0.075 * x ** 4, np.arcsin(xs) / xs)


def bent(mesh: SpringMesh, xyz: np.ndarray, normals: np.ndarray) -> SpringMesh:
    """``mesh`` with every spring's rest length and constant set for the arc of
    the surface it spans, at nodes ``xyz`` (n, 3) with unit normals ``normals``.

    A spring is a chord; the thread between its nodes lies on the surface,
    longer by f = :func:`arc_over_chord`. A chord at its lattice length leaves
    the thread stretched by (r kappa)^2 / 24 and the pattern that much short
    of a development (decision 0057). The bent spring has rest r / f and
    constant k f^2: its energy k f^2 (l - r / f)^2 / 2 is the arc's,
    k (f l - r)^2 / 2, for f held where the mesh was bent (the solver bends
    again where the nodes have moved since)."""
    a, b = mesh.ends[:, 0], mesh.ends[:, 1]
    f = arc_over_chord(xyz[b] - xyz[a], normals[a], normals[b])
    k = mesh.material.constants()[mesh.kind]
    rest = mesh.thread_rest() / f
    if mesh.ease:
        rest = rest * ease_factor(mesh, xyz)
    return replace(mesh, rest=rest, k=k * f * f)


def ease_factor(mesh: SpringMesh, xyz: np.ndarray) -> np.ndarray:
    """(m,) how much longer each spring of ``mesh`` rests for its ``ease`` at nodes ``xyz``: the product
    over the eased lines of 1 + amount w cos^2(theta), w = 1 - d / band (0 beyond the band) for the
    spring's middle at d from the line, theta its angle with the line's nearest segment."""
    a, b = mesh.ends[:, 0], mesh.ends[:, 1]
    d = xyz[b] - xyz[a]
    mid = 0.5 * (xyz[a] + xyz[b])
    out = np.ones(len(d))
    for line, amount, band in mesh.ease:
        line = np.asarray(line, dtype=float)
        seg, d2 = nearest_segments(mid, line)
        w = np.clip(1.0 - np.sqrt(d2) / band, 0.0, 1.0)
        t = line[seg + 1] - line[seg]
        along = np.einsum("ij,ij->i", d, t) ** 2 / np.maximum(
            np.einsum("ij,ij->i", d, d) * np.einsum("ij,ij->i", t, t), 1e-300)
        out *= 1.0 + amount * w * along
    return out


def lattice_index(ij: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A dense (R, C) grid of node indices (-1 where empty) and its offset.

    Node ``n`` sits at ``grid[ij[n, 0] - off[0], ij[n, 1] - off[1]]``; the grid
    has a one-cell margin of -1 all round so neighbours can be read by slicing.
    """
    off = ij.min(axis=0) - 1
    R, C = ij.max(axis=0) - off + 2
    grid = np.full((R, C), -1, dtype=np.int64)
    grid[ij[:, 0] - off[0], ij[:, 1] - off[1]] = np.arange(ij.shape[0])
    return grid, off


def build_mesh(ij: np.ndarray, r_weft: float, r_warp: float, material: Material,
               keep=None) -> SpringMesh:
    """Springs and cells of the nodes at lattice positions ``ij``.

    ``keep``, if given, is a function ``keep(ends (m, 2), kind (m,)) -> (m,) bool``
    that removes springs (darts use it to cut the springs crossing them).
    """
    ij = np.asarray(ij, dtype=np.int64).reshape(-1, 2)
    if ij.shape[0] == 0:
        raise SettingsError("the mesh has no nodes")
    grid, _ = lattice_index(ij)
    a = grid[:-1, :-1]  # (i, j)
    b = grid[:-1, 1:]   # (i, j+1)
    c = grid[1:, 1:]    # (i+1, j+1)
    d = grid[1:, :-1]   # (i+1, j)
    weft_mask = (grid[:, :-1] >= 0) & (grid[:, 1:] >= 0)
    warp_mask = (grid[:-1, :] >= 0) & (grid[1:, :] >= 0)
    weft = np.column_stack([grid[:, :-1][weft_mask], grid[:, 1:][weft_mask]])
    warp = np.column_stack([grid[:-1, :][warp_mask], grid[1:, :][warp_mask]])
    d1_mask = (a >= 0) & (c >= 0) & ((b >= 0) | (d >= 0))
    d2_mask = (b >= 0) & (d >= 0) & ((a >= 0) | (c >= 0))
    diag = np.concatenate([np.column_stack([a[d1_mask], c[d1_mask]]),
                           np.column_stack([b[d2_mask], d[d2_mask]])])
    ends = np.concatenate([weft, warp, diag]).astype(np.int64)
    kind = np.concatenate([np.full(len(weft), WEFT), np.full(len(warp), WARP),
                           np.full(len(diag), DIAG)]).astype(np.int8)
    r_diag = float(np.hypot(r_weft, r_warp))
    rest = np.array([r_weft, r_warp, r_diag])[kind]
    k = material.constants()[kind]
    if keep is not None:
        mask = np.asarray(keep(ends, kind), dtype=bool)
        ends, kind, rest, k = ends[mask], kind[mask], rest[mask], k[mask]
    # cells: four corners present and their four edges still springs
    full = (a >= 0) & (b >= 0) & (c >= 0) & (d >= 0)
    cells = np.column_stack([a[full], b[full], c[full], d[full]]).astype(np.int64)
    if keep is not None and len(cells):
        cells = cells[_cells_with_edges(cells, ends, kind, ij.shape[0])]
    return SpringMesh(ij=ij, ends=ends, kind=kind, rest=rest, k=k, cells=cells,
                      r_weft=float(r_weft), r_warp=float(r_warp), material=material)


def only_springs(mesh: SpringMesh, ends: np.ndarray) -> SpringMesh:
    """``mesh`` keeping only the springs whose node pairs are among ``ends``
    (m, 2), in either order; cells lose the ones whose edges went.

    A result file lists its springs: a solve can end with a lattice spring
    missing that a build at the same (u, v) would form (one a dart cut earlier
    that no longer crosses it), and the reopened result must be the saved one.
    """
    ends = np.asarray(ends, dtype=np.int64).reshape(-1, 2)
    n = mesh.n_nodes
    if len(ends) and (ends.min() < 0 or ends.max() >= n):
        raise SettingsError("the listed springs refer to missing nodes")
    e = np.sort(mesh.ends, axis=1)
    s = np.sort(ends, axis=1)
    keep = np.isin(e[:, 0] * n + e[:, 1], s[:, 0] * n + s[:, 1])
    if keep.all():
        return mesh
    ends_k, kind_k = mesh.ends[keep], mesh.kind[keep]
    cells = mesh.cells[_cells_with_edges(mesh.cells, ends_k, kind_k, n)] if len(mesh.cells) else mesh.cells
    return replace(mesh, ends=ends_k, kind=kind_k, rest=mesh.rest[keep], k=mesh.k[keep], cells=cells)


def _cells_with_edges(cells: np.ndarray, ends: np.ndarray, kind: np.ndarray, n: int) -> np.ndarray:
    """(c,) bool: cells whose four weft/warp edges are all present as springs."""
    thread = kind != DIAG
    e = np.sort(ends[thread], axis=1)
    keys = np.sort(e[:, 0] * n + e[:, 1])  # sorted once, searched four times (np.isin sorts every time)
    ok = np.ones(len(cells), dtype=bool)
    if len(keys) == 0:
        return ~ok
    for s, t in ((0, 1), (1, 2), (3, 2), (0, 3)):
        lo = np.minimum(cells[:, s], cells[:, t])
        hi = np.maximum(cells[:, s], cells[:, t])
        want = lo * n + hi
        ok &= keys[np.minimum(np.searchsorted(keys, want), len(keys) - 1)] == want
    return ok
