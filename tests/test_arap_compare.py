"""A panel cut from a real scan flattens as well as ARAP does (issue 40): the
isotropic sheet's pattern of a front panel drawn on a carved head's range scan
has boundary and area errors within libigl's as-rigid-as-possible
parameterisation of the same cut piece plus 0.2 percentage points.

The scan: pymeshlab 2025.7.post1's ``rangemaps/face000.ply`` (a single-view
range scan of a stone head, open at its back: a bust-like open mesh). ARAP
(Liu et al. 2008, libigl's ``arap_precomputation``/``arap_solve`` with dynamic
regularisation and no fixed vertices) starts from the piece's least-squares
conformal map, scaled to its area; its errors are measured as flatweave's
(``flatweave.geometry.numerics.outline_errors``: the outline's length and the
area against the piece's). The woven material is not held to ARAP's area: a
woven pattern's cells shear on the surface, so its area differs by design."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import package_file
from tests.test_real_scans import front_loop

try:
    import igl
except ImportError:
    igl = None

pytestmark = [pytest.mark.slow,
              # libigl is a dev dependency: an install without the dev extras skips this comparison, but
              # CI installs them, so there (CI set) a missing libigl fails instead of skipping
              pytest.mark.skipif(igl is None and not os.environ.get("CI"),
                                 reason="libigl is not installed (pip install libigl)")]


def arap_errors(V, F) -> dict:
    """ARAP's flat map of the piece (V, F): its boundary and area errors, percent."""
    from flatweave.geometry.meshfit import boundary_loops, lscm
    from flatweave.geometry.numerics import outline_errors

    def areas(X):
        if X.shape[1] == 2:
            e1, e2 = X[F[:, 1]] - X[F[:, 0]], X[F[:, 2]] - X[F[:, 0]]
            return 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
        return 0.5 * np.linalg.norm(np.cross(X[F[:, 1]] - X[F[:, 0]], X[F[:, 2]] - X[F[:, 0]]), axis=1).sum()

    start = lscm(V, F)
    start *= np.sqrt(areas(V) / areas(start))
    data = igl.ARAPData()
    data.max_iter = 100
    data.with_dynamics = True  # no vertex fixed: the dynamic term makes the system definite
    igl.arap_precomputation(np.ascontiguousarray(V), np.ascontiguousarray(F, dtype=np.int64), 2,
                            np.zeros(0, dtype=np.int32), data)
    uv = igl.arap_solve(np.zeros((0, 2)), data, np.ascontiguousarray(start))
    [outer] = boundary_loops(F)

    def length(X):
        return float(np.linalg.norm(X[outer] - X[np.roll(outer, -1)], axis=1).sum())

    return outline_errors(length(uv), length(V), areas(uv), areas(V))


def test_a_front_panel_of_a_head_scan_flattens_within_arap_plus_a_fifth_of_a_point():
    from flatweave.geometry.meshfit import clean_mesh
    from flatweave.geometry.region import cover_for
    from flatweave.method.lattice import MATERIALS
    from flatweave.method.pipeline import flatten
    from flatweave.method.settings import FlattenSettings
    from flatweave.reading.meshes import MeshFile, read_mesh

    head = Path(package_file("pymeshlab", "2025.7.post1", "rangemaps/face000.ply"))
    V, F = read_mesh(head)
    part, _, _ = clean_mesh(V, F, head.name, 0)
    centre = 0.5 * (part.min(axis=0) + part.max(axis=0))
    piece = MeshFile(head, V, F, 22).cut(front_loop(part, centre[:2], 30.0))
    arap = arap_errors(piece.vertices, piece.triangles)
    cover = cover_for(piece.surface, piece.region)
    m = flatten(piece.surface, FlattenSettings(1.0, seed=cover.default_seed, region=piece.region,
                                               material=MATERIALS["isotropic"]), area=cover.area).metrics
    assert m["nodes"] > 3000  # a millimetre's spacing on a panel 65 mm across
    for key in ("boundary_error_pct", "area_error_pct"):
        assert m[key] <= arap[key] + 0.2, (key, m[key], arap[key])
    assert arap["boundary_error_pct"] > 0.5  # the piece is not developable: ARAP's outline is off too
