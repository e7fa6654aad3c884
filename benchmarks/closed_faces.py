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
