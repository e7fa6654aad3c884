"""How close a closed face's pattern comes to its development (issue 40's 0.02 %).

Measured by ``benchmarks/suite.py`` (case ``closed_cylinder``): the full
cylinder face of a STEP file made with Open CASCADE (tests/cadfiles.py's
``cylinder_solid``: radius 5, height 12, periodic, one seam edge), read as
the CLI reads it and flattened woven at ``radius / size`` spacing (size 4:
spacing / radius 0.25; 20: 0.05). The development is the 2 pi R x h
rectangle; the errors are the larger of the area's and the boundary's,
signed values alongside, with the shortfall (r / R)^2 / 24 that springs as
chords at their lattice length left (docs/decisions/0056) for comparison; the
springs are bent to their arcs since docs/decisions/0057.

And (case ``tube_seam``) the same for a tube-shaped mesh opened along a drawn
seam (docs/decisions/0058): a binary STL of an open cylinder (radius 50,
height 120; tests/helpers.py's ``tube``, its vertices jittered along the
surface and its diagonals random, as a scan's triangles are irregular) read,
opened along a straight seam and fitted as ``flatten --seam`` does (timed),
then flattened woven at 5 mm spacing: the larger of the area and boundary
errors against the fitted surface, and the fitted area against 2 pi R H.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

RADIUS = 5.0


def measure(per_radius: int) -> dict:
    import flatweave.reading.cad as cad
    from flatweave.method.pipeline import flatten
    from flatweave.method.settings import FlattenSettings
    from tests import cadfiles as cf

    spacing = RADIUS / per_radius
    with tempfile.TemporaryDirectory(prefix="closed_faces_") as tmp:
        face = cad.read_cad_faces(cf.write_step(cf.cylinder_solid(), Path(tmp) / "cylinder.step")).faces[0]
    if face.kind != "cylinder" or face.trimmed:
        raise RuntimeError(f"expected the untrimmed cylinder face first, got a {face.kind} face")
    t0 = time.perf_counter()
    r = flatten(face.surface, FlattenSettings(spacing))
    seconds = time.perf_counter() - t0
    m = r.metrics
    return {"error_pct": max(m["area_error_pct"], m["boundary_error_pct"]),
            "area_signed_pct": m["area_error_signed_pct"], "boundary_signed_pct": m["boundary_error_signed_pct"],
            "chords_pct": 100 * (spacing / RADIUS) ** 2 / 24, "nodes": m["nodes"], "seconds": seconds}


def measure_tube(triangles: int) -> dict:
    import numpy as np
    import trimesh

    from flatweave.method.pipeline import flatten
    from flatweave.method.settings import FlattenSettings
    from flatweave.reading.meshes import mesh_to_cut
    from tests.helpers import TUBE_H, TUBE_R, tube

    m = max(int(round(np.sqrt(triangles / (2 * 2.6)))), 4)  # rows up; about 2.6 times as many round (2 pi R / H)
    n = max(int(round(triangles / (2 * (m - 1)))), 8)
    V, F = tube(n, m, jitter=0.3)
    seam = {"seam3d": [[TUBE_R, 0.0, 1.0], [TUBE_R, 0.0, TUBE_H - 1.0]]}
    with tempfile.TemporaryDirectory(prefix="tube_seam_") as tmp:
        path = Path(tmp) / "tube.stl"
        path.write_bytes(trimesh.Trimesh(V, F, process=False).export(file_type="stl"))
        t0 = time.perf_counter()
        piece = mesh_to_cut(path).mesh.seam_spec(seam)
        open_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    r = flatten(piece.surface, FlattenSettings(5.0, region=piece.region))
    m = r.metrics
    return {"error_pct": max(m["area_error_pct"], m["boundary_error_pct"]),
            "area_signed_pct": m["area_error_signed_pct"], "boundary_signed_pct": m["boundary_error_signed_pct"],
            "area_vs_cylinder_pct": 100 * (m["area_3d"] / (2 * np.pi * TUBE_R * TUBE_H) - 1),
            "open_cut_fit_s": open_s, "solve_s": time.perf_counter() - t0, "triangles": len(F)}
