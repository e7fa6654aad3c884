"""The energy EN of equation (4) over the nodes' (u, v), and its gradient.

EN = sum over springs of k/2 (l - r)^2  +  sum over constrained yarns of Dir,

with l the chord length between the spring's end nodes on the surface. The
directional term of section 2.3 holds every node of a chosen weft row or warp
column to a plane a x + b y + c z + d = 0. The paper writes it as k |f|; we use
k/2 f^2 with f the signed distance to the plane: smooth, so the Newton-type
solver converges quadratically, the same form as the spring terms, and, as in
the paper, a large k forces the yarn into the plane.

Everything is vectorised over springs and nodes: forces are accumulated in 3D
with ``np.bincount`` and mapped to (u, v) through the surface's first
derivatives, so one evaluation costs one surface evaluation plus O(m) array
arithmetic.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from flatweave.errors import SettingsError
from flatweave.method.lattice import SpringMesh
from flatweave.geometry.nurbs import NurbsSurface

__all__ = ["YarnConstraint", "Energy", "parse_yarn", "yarn_index", "yarn_nodes", "yarn_plane", "turn_plane",
           "resolve_yarns"]


@dataclass(frozen=True)
class YarnConstraint:
    """A weft row or warp column held to a plane (paper section 2.3).

    kind : "weft" (a row, lattice index i) or "warp" (a column, index j)
    index : the row or column, in lattice indices (the seed node is M[0, 0]);
        with a ``point``, the row or column that point resolved to on the
        current lattice (:meth:`resolved`)
    plane : (a, b, c, d) of a x + b y + c z + d = 0
    k : weight
    point : (x, y, z) the designer picked on the surface, or None. A yarn
        with a point is the thread through it: after every drape the
        pipeline takes the row (weft) or column (warp) of the node nearest
        the point (:func:`resolve_yarns`), so it stays the same thread when
        the spacing, seed or angle change the lattice. Without a point the
        index is explicit and kept as it is.
    """

    kind: str
    index: int
    plane: tuple[float, float, float, float]
    k: float
    point: tuple[float, float, float] | None = None

    def __post_init__(self):
        if self.kind not in ("weft", "warp"):
            raise SettingsError(f"yarn kind must be 'weft' or 'warp', got {self.kind!r}")
        if isinstance(self.index, bool) or not isinstance(self.index, (int, np.integer)):
            raise SettingsError(f"yarn index must be an integer, got {self.index!r}")
        if self.point is not None:
            q = np.asarray(self.point, dtype=float) if _numbers(self.point) else np.zeros(0)
            if q.shape != (3,) or not np.all(np.isfinite(q)):
                raise SettingsError(f"yarn point {self.point!r} must be three finite numbers X,Y,Z")
            object.__setattr__(self, "point", tuple(float(x) for x in q))
        p = np.asarray(self.plane, dtype=float)
        if p.shape != (4,) or not np.all(np.isfinite(p)) or not np.any(p[:3]):
            raise SettingsError(f"yarn plane {self.plane!r} must be four numbers A,B,C,D with (A,B,C) != 0")
        if not (np.isfinite(self.k) and self.k >= 0):
            raise SettingsError(f"yarn weight k must be a non-negative number, got {self.k!r}")

    def to_dict(self) -> dict:
        """The constraint as a JSON object (project and result files): kind,
        index (as resolved), plane, k and, for a picked yarn, point."""
        out = {"kind": self.kind, "index": int(self.index), "plane": [float(x) for x in self.plane],
               "k": float(self.k)}
        if self.point is not None:
            out["point"] = [float(x) for x in self.point]
        return out

    @classmethod
    def from_dict(cls, item: dict, read, what: str) -> "YarnConstraint":
        """The inverse of :meth:`to_dict`; ``read`` does the typed reads (as
        for darts, :func:`flatweave.method.darts.dart_from_dict`). ``point`` is optional
        (files before it hold the index only)."""
        point = item.get("point")
        return cls(read.string(read.get(item, "kind", what), f"{what}.kind"),
                   read.integer(read.get(item, "index", what), f"{what}.index"),
                   read.numbers(read.get(item, "plane", what), 4, f"{what}.plane"),
                   read.number(read.get(item, "k", what), f"{what}.k"),
                   None if point is None else read.numbers(point, 3, f"{what}.point"))

    def label(self) -> str:
        """What the designer picked: "weft through (0.12, 0.34, 0.56)" for a
        yarn with a point, "weft row -12" / "warp column 3" for an index."""
        if self.point is not None:
            return f"{self.kind} through ({', '.join(f'{x:.3g}' for x in self.point)})"
        return f"{self.kind} {'row' if self.kind == 'weft' else 'column'} {int(self.index)}"

    def identity(self) -> dict:
        """What decides the constraint, for comparing settings: a picked yarn
        is its point (its index follows from the point and the drape)."""
        d = self.to_dict()
        if self.point is not None:
            del d["index"]
        return d

    def resolved(self, mesh: SpringMesh, xyz: np.ndarray, tree: cKDTree | None = None) -> "YarnConstraint":
        """This yarn on the lattice of ``mesh`` (nodes at ``xyz (n, 3)``): with
        a point, the row (weft) or column (warp) of the node nearest it in
        3D; without one, itself."""
        if self.point is None or mesh.n_nodes == 0:
            return self
        tree = cKDTree(np.asarray(xyz, dtype=float)) if tree is None else tree
        node = int(tree.query(np.asarray(self.point, dtype=float))[1])
        index = yarn_index(mesh, node, self.kind)
        return self if index == self.index else replace(self, index=index)

    def nodes(self, mesh: SpringMesh) -> np.ndarray:
        """Indices of the mesh nodes on this yarn."""
        col = 0 if self.kind == "weft" else 1
        return np.flatnonzero(mesh.ij[:, col] == self.index)

    def unit_plane(self) -> np.ndarray:
        """(4,) plane scaled so (a, b, c) is a unit normal: f is a signed distance."""
        p = np.asarray(self.plane, dtype=float)
        p = p / np.abs(p[:3]).max()  # first to about 1: coefficients like 1e308 do not overflow the norm
        return p / np.linalg.norm(p[:3])


def _numbers(value) -> bool:
    try:
        return all(isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool)
                   for x in value)
    except TypeError:
        return False


def resolve_yarns(yarns, mesh: SpringMesh, xyz: np.ndarray) -> tuple:
    """Every yarn on the lattice of ``mesh`` (:meth:`YarnConstraint.resolved`)."""
    yarns = tuple(yarns)
    if not any(y.point is not None for y in yarns) or mesh.n_nodes == 0:
        return yarns
    tree = cKDTree(np.asarray(xyz, dtype=float))
    return tuple(y.resolved(mesh, xyz, tree) for y in yarns)


def parse_yarn(spec: str, plane: str, k: float) -> YarnConstraint:
    """``weft:I`` or ``warp:J`` (a lattice index) or ``weft@X,Y,Z`` /
    ``warp@X,Y,Z`` (the thread through the lattice node nearest that point,
    found after the drape) and ``A,B,C,D`` into a YarnConstraint."""
    point = None
    if "@" in spec:
        kind, _, at = spec.partition("@")
        try:
            point = tuple(float(x) for x in at.split(","))
        except ValueError:
            point = ()
        if len(point) != 3 or not all(np.isfinite(point)):
            raise SettingsError(f"yarn {spec!r} must be weft@X,Y,Z or warp@X,Y,Z (three numbers)")
        index = 0  # resolved after the drape
    else:
        try:
            kind, idx = spec.split(":")
            index = int(idx)
        except ValueError:
            raise SettingsError(f"yarn {spec!r} must be weft:ROW, warp:COLUMN (an integer), "
                                f"weft@X,Y,Z or warp@X,Y,Z") from None
    try:
        values = tuple(float(x) for x in plane.split(","))
    except ValueError:
        values = ()
    if len(values) != 4:
        raise SettingsError(f"yarn plane {plane!r} must be four numbers A,B,C,D")
    return YarnConstraint(kind.strip().lower(), index, values, float(k), point)


def yarn_index(mesh: SpringMesh, node: int, kind: str) -> int:
    """The lattice index of the weft row (kind "weft") or warp column ("warp") through ``node``."""
    if kind not in ("weft", "warp"):
        raise SettingsError(f"yarn kind must be 'weft' or 'warp', got {kind!r}")
    return int(mesh.ij[node, 0 if kind == "weft" else 1])


def yarn_nodes(mesh: SpringMesh, kind: str, index: int) -> np.ndarray:
    """Indices of the nodes of a weft row or warp column, in order along it
    (by their lattice column for a row, row for a column)."""
    nodes = YarnConstraint(kind, index, (1.0, 0.0, 0.0, 0.0), 0.0).nodes(mesh)
    along = mesh.ij[nodes, 1 if kind == "weft" else 0]
    return nodes[np.argsort(along, kind="stable")]


def _unit(v: np.ndarray) -> np.ndarray:
    n = float(np.linalg.norm(v))
    if not (np.isfinite(n) and n > 0):
        raise SettingsError("the yarn's plane is undefined (a zero direction)")
    return v / n


def yarn_plane(ends: np.ndarray, normal: np.ndarray) -> tuple[float, float, float, float]:
    """The plane (a, b, c, d), unit (a, b, c), through the yarn's end points
    ``ends`` (2, 3) that contains the direction ``normal`` (3,) (the surface
    normal at the picked node): the yarn's default direction plane (paper 2.3)."""
    ends = np.asarray(ends, dtype=float)
    n = _unit(np.asarray(normal, dtype=float))
    chord = ends[1] - ends[0]
    if not np.linalg.norm(chord) > 0:
        raise SettingsError("the yarn's end points coincide: it has no direction")
    m = np.cross(chord, n)
    if np.linalg.norm(m) <= 1e-9 * np.linalg.norm(chord):
        raise SettingsError("the yarn runs along the surface normal: no plane through it contains the normal")
    m = _unit(m)
    return (float(m[0]), float(m[1]), float(m[2]), float(-m @ ends[0]))


def turn_plane(plane, point: np.ndarray, normal: np.ndarray, angle_deg: float) -> tuple[float, float, float, float]:
    """``plane`` (a, b, c, d) turned by ``angle_deg`` about the line that runs
    through the foot of ``point`` on the plane along ``normal`` (projected into
    the plane): the yarn's direction turned in the surface's tangent plane,
    positive counter-clockwise seen from the side ``normal`` points to.
    The result has a unit normal; angle 0 gives the same plane, normalised."""
    p = np.asarray(plane, dtype=float)
    scale = np.linalg.norm(p[:3])
    if not scale > 0:
        raise SettingsError("the plane has no normal")
    m, d = p[:3] / scale, p[3] / scale
    x = np.asarray(point, dtype=float)
    foot = x - (m @ x + d) * m
    n = np.asarray(normal, dtype=float)
    axis = n - (n @ m) * m
    if not np.linalg.norm(axis) > 1e-9 * max(np.linalg.norm(n), 1e-300):
        raise SettingsError("the surface normal is perpendicular to the plane: cannot turn about it")
    axis = _unit(axis)
    a = np.radians(float(angle_deg))
    m2 = m * np.cos(a) + np.cross(axis, m) * np.sin(a) + axis * (axis @ m) * (1 - np.cos(a))
    m2 = _unit(m2)
    return (float(m2[0]), float(m2[1]), float(m2[2]), float(-m2 @ foot))


class Energy:
    """EN(uv) for one surface, mesh topology and set of yarn constraints.

    Caches only what depends on topology (spring arrays, constrained nodes).
    """

    def __init__(self, surface: NurbsSurface, mesh: SpringMesh, yarns=()):
        self.surface = surface
        self.mesh = mesh
        self.n = mesh.n_nodes
        self.a = mesh.ends[:, 0]
        self.b = mesh.ends[:, 1]
        self.k = mesh.k
        self.rest = mesh.rest
        nodes, planes, weights = [], [], []
        for y in yarns:
            idx = y.nodes(mesh)
            nodes.append(idx)
            planes.append(np.repeat(y.unit_plane()[None, :], len(idx), axis=0))
            weights.append(np.full(len(idx), float(y.k)))
        self.dir_nodes = np.concatenate(nodes) if nodes else np.zeros(0, dtype=np.int64)
        self.dir_planes = np.concatenate(planes) if planes else np.zeros((0, 4))
        self.dir_k = np.concatenate(weights) if weights else np.zeros(0)

    def rebent(self, mesh: SpringMesh) -> "Energy":
        """The same energy with the rest lengths and constants of ``mesh``, a mesh
        with this one's springs (:func:`flatweave.method.lattice.bent` again)."""
        out = object.__new__(Energy)
        out.__dict__.update(self.__dict__)
        out.mesh, out.k, out.rest = mesh, mesh.k, mesh.rest
        return out

    def masked(self, spring_on: np.ndarray, node_on: np.ndarray) -> "Energy":
        """The same energy with springs ``~spring_on`` and the yarn terms of
        nodes ``~node_on`` switched off (constants set to zero); topology and
        node numbering are kept, so a solver's sparse pattern stays valid."""
        out = object.__new__(Energy)
        out.__dict__.update(self.__dict__)
        out.k = np.where(spring_on, self.k, 0.0)
        out.dir_k = np.where(node_on[self.dir_nodes], self.dir_k, 0.0) if self.dir_nodes.size else self.dir_k
        return out

    # ------------------------------------------------------------ pieces
    def spring_energy(self, xyz: np.ndarray) -> np.ndarray:
        """(m,) energy of every spring."""
        length = np.linalg.norm(xyz[self.a] - xyz[self.b], axis=1)
        return 0.5 * self.k * (length - self.rest) ** 2

    def dir_distance(self, xyz: np.ndarray) -> np.ndarray:
        """(c,) signed distances of the constrained nodes to their planes."""
        P = self.dir_planes
        return np.einsum("ij,ij->i", xyz[self.dir_nodes], P[:, :3]) + P[:, 3]

    def value_xyz(self, xyz: np.ndarray) -> float:
        """EN for nodes at xyz : (n, 3)."""
        f = self.dir_distance(xyz)
        return float(self.spring_energy(xyz).sum() + 0.5 * np.dot(self.dir_k, f * f))

    def value(self, uv: np.ndarray) -> float:
        """EN at uv : (n, 2)."""
        return self.value_xyz(self.surface.points(uv))

    def force_xyz(self, xyz: np.ndarray, d: np.ndarray | None = None,
                  length: np.ndarray | None = None) -> tuple[float, np.ndarray]:
        """EN and its gradient with respect to the 3D node positions, (n, 3).
        ``d`` (m, 3) and ``length`` (m,): the springs' xyz[a] - xyz[b] and their
        lengths when the caller has them already (the solver's residuals)."""
        if d is None:
            d = xyz[self.a] - xyz[self.b]
        if length is None:
            length = np.linalg.norm(d, axis=1)
        ext = length - self.rest
        coef = self.k * ext / np.maximum(length, 1e-300)
        g = d * coef[:, None]
        G = np.empty((self.n, 3))
        for c in range(3):
            G[:, c] = (np.bincount(self.a, g[:, c], minlength=self.n)
                       - np.bincount(self.b, g[:, c], minlength=self.n))
        e = 0.5 * np.dot(self.k, ext * ext)
        if self.dir_nodes.size:
            f = self.dir_distance(xyz)
            e += 0.5 * np.dot(self.dir_k, f * f)
            gd = (self.dir_k * f)[:, None] * self.dir_planes[:, :3]
            for c in range(3):
                G[:, c] += np.bincount(self.dir_nodes, gd[:, c], minlength=self.n)
        return float(e), G

    def value_and_grad(self, uv: np.ndarray) -> tuple[float, np.ndarray]:
        """EN and dEN/d(u, v), (n, 2), at uv : (n, 2)."""
        S, Su, Sv = self.surface.derivatives(uv)
        e, G = self.force_xyz(S)
        return e, np.column_stack([np.einsum("ij,ij->i", G, Su), np.einsum("ij,ij->i", G, Sv)])
