"""How long joining several CAD faces takes (``--faces``, ``flatweave.reading.cadjoin.join_faces``).

Measured by ``benchmarks/suite.py`` (case ``faces_join``): a STEP file is made
with Open CASCADE (the shapes of tests/test_faces_join.py): at 3 faces a
plate, a quarter-cylinder fillet and a plate; at 9 the lid of a box with
rounded edges (a plane, four cylinders, four sphere corners). It is read as
the CLI reads it (``read_cad_faces``, a child process), then the faces are
joined (a child that tessellates them, welding and densifying, repair, the
map and fit). The fit's largest deviation is a percentage of the joined
faces' bounding-box diagonal.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path


def measure(faces: int) -> dict:
    import flatweave.reading.cad as cad
    from flatweave.reading.cadjoin import join_faces
    from tests import cadfiles as cf
    from tests.test_faces_join import fillet_shell, lid_faces, rounded_box

    with tempfile.TemporaryDirectory(prefix="faces_join_") as tmp:
        if faces == 3:
            path, pick = cf.write_step(fillet_shell(), Path(tmp) / "fillet.step"), (lambda c: (0, 1, 2))
        elif faces == 9:
            path, pick = cf.write_step(rounded_box(), Path(tmp) / "rounded.step"), lid_faces
        else:
            raise ValueError(f"faces_join measures 3 or 9 faces, not {faces}")
        t0 = time.perf_counter()
        cad_file = cad.read_cad_faces(path)
        read = time.perf_counter() - t0
        t1 = time.perf_counter()
        piece = join_faces(cad_file, pick(cad_file))
        join = time.perf_counter() - t1
    fit = piece.fit
    if len(fit.faces) != faces:
        raise RuntimeError(f"joined {len(fit.faces)} faces, not {faces}")
    return {"seconds": read + join, "read_s": read, "join_s": join,
            "max_dev_pct": 100 * fit.max_deviation / fit.size, "triangles": float(fit.triangles)}
