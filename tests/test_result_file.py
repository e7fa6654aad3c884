"""The result file's compact arrays (issue 44, result version 2): a 200,000-node result written and read
back through the file is the same result; the arrays decode with numpy, zlib and base64 alone; damaged
or oversized array entries are one line; a version-1 file (JSON lists) still reads."""

from __future__ import annotations

import base64
import json
import zlib

import numpy as np
import pytest

from flatweave.document.project import result_from_dict
from flatweave.errors import FlatweaveError, SettingsError
from flatweave.files import decode_array, encode_array, write_json
from flatweave.geometry.quadrature import region_area
from flatweave.method.lattice import MATERIALS
from flatweave.method.pipeline import flatten, state_from_dict
from flatweave.method.result import result_to_dict
from flatweave.method.settings import FlattenSettings
from flatweave.reading.examples import load_example


def _numpy_only(v) -> np.ndarray:
    """An encoded array read as the guide says, without flatweave."""
    return np.frombuffer(zlib.decompress(base64.b64decode(v["zlib_base64"])), v["dtype"]).reshape(v["shape"])


@pytest.mark.slow
def test_a_200000_node_result_round_trips_through_the_file(tmp_path):
    octant = load_example("octant")
    area = float(region_area(octant))
    settings = FlattenSettings(float(np.sqrt(area / 200_000)), material=MATERIALS["woven"], solver="none")
    r = flatten(octant, settings, area=area)  # the drape alone: the file, not the solve, is what is tested
    assert r.mesh.n_nodes >= 190_000
    path = tmp_path / "big.json"
    write_json(path, result_to_dict(r, "octant"))
    raw = path.read_bytes()
    # compact: the version-1 lists took about 530 bytes a node (85 MB at 160,000)
    assert len(raw) < 160 * r.mesh.n_nodes, len(raw)
    doc = json.loads(raw)
    assert doc["version"] == 2
    nodes, springs, cells = doc["nodes"], doc["springs"], doc["cells"]
    np.testing.assert_array_equal(_numpy_only(nodes["ij"]), r.mesh.ij)
    np.testing.assert_array_equal(_numpy_only(nodes["uv"]), r.uv)  # bit for bit: float64
    np.testing.assert_array_equal(_numpy_only(nodes["xy"]), r.pattern.xy)
    np.testing.assert_array_equal(_numpy_only(nodes["xyz"]), r.xyz)
    np.testing.assert_array_equal(_numpy_only(springs["ends"]), r.mesh.ends)
    np.testing.assert_array_equal(_numpy_only(springs["rest"]), r.mesh.rest)
    assert [springs["kind_names"][k] for k in _numpy_only(springs["kind"])[:3]] == \
        [("weft", "warp", "diag")[k] for k in r.mesh.kind[:3]]
    np.testing.assert_array_equal(_numpy_only(cells["corners"]), r.mesh.cells)
    length = np.linalg.norm(r.xyz[r.mesh.ends[:, 1]] - r.xyz[r.mesh.ends[:, 0]], axis=1)
    np.testing.assert_allclose(_numpy_only(springs["length"]), length, rtol=1e-7)  # float32: measured values
    # read back as a result (the pattern and metrics rebuilt from ij, uv and ends): the same pattern
    back = result_from_dict(doc, octant, str(path))
    assert back.mesh.n_nodes == r.mesh.n_nodes and np.array_equal(back.mesh.ends, r.mesh.ends)
    np.testing.assert_allclose(back.pattern.xy, r.pattern.xy, rtol=0, atol=1e-12)
    assert back.metrics["boundary_error_pct"] == pytest.approx(r.metrics["boundary_error_pct"], abs=1e-9)


def test_a_version_1_result_with_lists_still_reads():
    octant = load_example("octant")
    r = flatten(octant, FlattenSettings(0.15, material=MATERIALS["woven"]))
    doc = result_to_dict(r, "octant")
    old = json.loads(json.dumps(doc))
    old["version"] = 1
    for group in ("nodes", "springs", "cells"):
        for key, v in list(old[group].items()):
            if isinstance(v, dict):
                old[group][key] = _numpy_only(v).tolist()
    state = state_from_dict(old, octant, r.settings)
    np.testing.assert_array_equal(state.uv, r.uv)
    back = result_from_dict(old, octant)
    np.testing.assert_allclose(back.pattern.xy, r.pattern.xy, atol=1e-12)


@pytest.mark.parametrize("damage, says", [
    (lambda v: v.update(dtype="<f2"), "an encoded array"),
    (lambda v: v.update(shape=[3, -1]), "shape must be"),
    (lambda v: v.update(shape=[10 ** 6, 10 ** 6]), "past what a file may hold"),
    (lambda v: v.update(zlib_base64="not base64!"), "damaged"),
    (lambda v: v.update(zlib_base64=base64.b64encode(zlib.compress(b"\0" * 8)).decode()), "holds 8 bytes"),
    # a zip bomb: a few hundred bytes that would expand to 100 MB are read no further than the shape asks
    (lambda v: v.update(zlib_base64=base64.b64encode(zlib.compress(b"\0" * 100_000_000)).decode()),
     "more than the 48 bytes"),
])
def test_a_damaged_array_is_one_line(damage, says):
    v = encode_array(np.arange(6.0).reshape(3, 2), "<f8")
    damage(v)
    with pytest.raises(FlatweaveError, match=says) as info:
        decode_array(v, "nodes.uv")
    assert "\n" not in str(info.value) and "nodes.uv" in str(info.value)
    with pytest.raises(SettingsError):
        decode_array({"dtype": "<f8"}, "nodes.uv", SettingsError)
    with pytest.raises(ValueError, match="not finite"):
        encode_array(np.array([1.0, np.nan]), "<f8")
