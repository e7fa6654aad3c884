"""geomdl JSON surface files: bad files, round trips with geomdl, and fuzzing."""

from __future__ import annotations

import copy
import json
import math
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from geomdl import BSpline, NURBS, exchange
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from flatweave.errors import SurfaceError
from flatweave.reading.examples import example_names, example_path
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.geometry.surface_json import (dumps_surface, load_surface, parse_surface_json, save_surface,
                             surface_from_json_dict, surface_to_json_dict)

BAD = Path(__file__).parent / "data" / "bad"

# file -> a word the message must contain (case-insensitive)
BAD_FILES = {
    "not_json.json": "not valid json",
    "truncated.json": "line",
    "empty.json": "empty",
    "whitespace_only.json": "empty",
    "binary_garbage.json": "binary",
    "nul_bytes.json": "binary",
    "utf16_text.json": "utf-8",
    "deeply_nested.json": "nested",
    "not_object.json": "object",
    "string_document.json": "object",
    "shape_not_object.json": "object",
    "missing_shape.json": "missing key 'shape'",
    "missing_data.json": "missing key 'data'",
    "missing_knotvector_u.json": "missing key 'knotvector_u'",
    "missing_degree_v.json": "missing key 'degree_v'",
    "missing_control_points.json": "missing key 'control_points'",
    "missing_points.json": "missing key 'points'",
    "curve.json": "curve",
    "volume.json": "volume",
    "unknown_shape_type.json": "surface",
    "wrong_entry_type.json": "spline",
    "multi_surface.json": "2 surfaces",
    "count_mismatch.json": "count",
    "no_surface.json": "no surface",
    "trimmed.json": "trim",
    "degree_string.json": "integer",
    "degree_float.json": "integer",
    "degree_bool.json": "integer",
    "degree_zero.json": "at least 1",
    "size_null.json": "integer",
    "point_coordinate_string.json": "must be a number",
    "weight_string.json": "must be a number",
    "knots_not_list.json": "list",
    "points_not_list.json": "list",
    "point_not_list.json": "list",
    "rational_not_bool.json": "true or false",
    "knots_wrong_length.json": "knots",
    "knots_decreasing.json": "non-decreasing",
    "knots_multiplicity.json": "multiplicity",
    "knots_empty_domain.json": "empty parameter domain",
    "point_count_mismatch.json": "count mismatch",
    "points_4d.json": "3d",
    "points_1d.json": "3d",
    "points_mixed_dimensions.json": "3d",
    "points_dimension_mismatch.json": "dimension",
    "nan_literal.json": "finite",
    "infinity_literal.json": "finite",
    "negative_infinity_weight.json": "finite",
    "overflow_number.json": "finite",
    "huge_integer.json": "too large",
    "too_large_value.json": "too large",
    "weight_zero.json": "positive",
    "weight_negative.json": "positive",
    "weights_count_mismatch.json": "weight count",
    "degree_too_high.json": "too high",
    "all_points_equal.json": "equal",
    "huge_surface.json": "too large",  # each number allowed, the net 4e60 across: overflow in evaluation
    "tiny_coordinates.json": "no usable area",  # 1e-300 across: the area underflows to 0
    "weights_ratio.json": "ratio",  # weights 1e-6 .. 1e6
}


def assert_one_line(msg: str) -> None:
    assert msg and "\n" not in msg and "\r" not in msg and len(msg) <= 400


# ---------------------------------------------------------------------- bad files
def test_every_bad_file_has_an_expectation():
    assert {p.name for p in BAD.glob("*.json")} == set(BAD_FILES)


@pytest.mark.parametrize("name", sorted(BAD_FILES))
def test_bad_file_gives_one_line_surface_error(name):
    path = BAD / name
    with pytest.raises(SurfaceError) as info:
        load_surface(path)
    msg = str(info.value)
    assert_one_line(msg)
    assert msg.startswith(str(path) + ": ")
    assert BAD_FILES[name] in msg.lower()


@pytest.mark.slow
@pytest.mark.parametrize("name", ["truncated.json", "binary_garbage.json", "nan_literal.json", "huge_surface.json",
                                  "tiny_coordinates.json", "multi_surface.json"])
def test_bad_file_through_the_cli_is_one_line_and_status_2(tmp_path, name):
    out = tmp_path / "r.json"
    p = subprocess.run([sys.executable, "-m", "flatweave", "flatten", str(BAD / name), "--spacing", "0.1",
                        "--out", str(out)], capture_output=True, text=True, timeout=120)
    lines = [line for line in p.stderr.splitlines() if line.strip()]
    assert p.returncode == 2 and len(lines) == 1, p.stderr
    assert lines[0].startswith(f"flatweave: error: {BAD / name}: ") and BAD_FILES[name] in lines[0].lower()
    assert "Traceback" not in p.stderr and not p.stdout and not out.exists()


def test_not_json_names_line_and_column():
    with pytest.raises(SurfaceError, match=r"line \d+, column \d+"):
        load_surface(BAD / "not_json.json")


def test_multi_surface_says_so():
    with pytest.raises(SurfaceError, match="one surface per file"):
        load_surface(BAD / "multi_surface.json")


@pytest.mark.parametrize("name", ["curve.json", "volume.json"])
def test_geomdl_reads_the_curve_and_volume_we_refuse(name):
    # they are genuine geomdl files of the wrong kind, not broken ones
    assert len(exchange.import_json(str(BAD / name))) == 1


def test_missing_file_and_directory(tmp_path):
    for path, words in ((tmp_path / "nope.json", "no such file"), (tmp_path, "is a folder, not a file")):
        with pytest.raises(SurfaceError, match=words) as info:
            load_surface(path)
        assert_one_line(str(info.value))


def test_newline_in_file_name_stays_one_line(tmp_path):
    path = tmp_path / "two\nlines.json"
    path.write_text("{", encoding="utf-8")
    with pytest.raises(SurfaceError) as info:
        load_surface(path)
    assert_one_line(str(info.value))


# ---------------------------------------------------------------------- good inputs
def random_surface(rng: np.random.Generator, rational: bool = True) -> NurbsSurface:
    p, q = (int(x) for x in rng.integers(1, 4, 2))
    nu, nv = p + 1 + int(rng.integers(0, 4)), q + 1 + int(rng.integers(0, 4))

    def knots(n, deg):
        inner = np.sort(rng.uniform(0.05, 0.95, n - deg - 1))
        return np.concatenate([np.zeros(deg + 1), inner, np.ones(deg + 1)]) * 2.5 - 0.7

    W = rng.uniform(0.3, 3.0, (nu, nv)) if rational else None
    return NurbsSurface(p, q, knots(nu, p), knots(nv, q), rng.normal(size=(nu, nv, 3)), W)


def assert_same_surface(a: NurbsSurface, b: NurbsSurface) -> None:
    assert (a.degree_u, a.degree_v, a.shape) == (b.degree_u, b.degree_v, b.shape)
    for x, y in ((a.knots_u, b.knots_u), (a.knots_v, b.knots_v), (a.ctrlpts, b.ctrlpts),
                 (a.weights, b.weights)):
        np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("seed", range(6))
def test_round_trip_is_exact(tmp_path, seed):
    s = random_surface(np.random.default_rng(seed), rational=seed % 3 != 0)
    path = tmp_path / "s.json"
    save_surface(s, path)
    back = load_surface(path)
    assert_same_surface(s, back)
    assert back.rational == s.rational
    assert dumps_surface(back) == path.read_text(encoding="utf-8")
    assert not list(tmp_path.glob("*.tmp"))


@pytest.mark.parametrize("seed", range(6))
def test_geomdl_reads_what_we_write(tmp_path, seed):
    s = random_surface(np.random.default_rng(100 + seed), rational=seed % 2 == 0)
    path = tmp_path / "s.json"
    save_surface(s, path)
    (g,) = exchange.import_json(str(path))
    nu, nv = s.shape
    assert (g.degree_u, g.degree_v, g.ctrlpts_size_u, g.ctrlpts_size_v) == (s.degree_u, s.degree_v, nu, nv)
    # geomdl stores w * P and divides on the way out: last-bit differences for rational nets
    np.testing.assert_allclose(np.array(g.ctrlpts), s.ctrlpts.reshape(-1, 3), rtol=1e-15, atol=1e-16)
    np.testing.assert_array_equal(np.array(g.weights), s.weights.ravel())
    # geomdl rescales knot vectors to [0, 1]; map our parameters the same way
    ku, kv = s.knots_u, s.knots_v
    np.testing.assert_allclose(g.knotvector_u, (ku - ku[0]) / (ku[-1] - ku[0]), atol=1e-15)
    rng = np.random.default_rng(seed)
    (u0, u1), (v0, v1) = s.domain
    uv = np.column_stack([rng.uniform(u0, u1, 20), rng.uniform(v0, v1, 20)])
    st_uv = np.column_stack([(uv[:, 0] - ku[0]) / (ku[-1] - ku[0]), (uv[:, 1] - kv[0]) / (kv[-1] - kv[0])])
    ref = np.array(g.evaluate_list([tuple(x) for x in st_uv]))
    np.testing.assert_allclose(s.points(uv), ref, atol=1e-12)


def _geomdl_surface(rational: bool):
    rng = np.random.default_rng(5)
    g = NURBS.Surface() if rational else BSpline.Surface()
    g.degree_u, g.degree_v = 2, 3
    g.ctrlpts_size_u, g.ctrlpts_size_v = 4, 5
    g.ctrlpts = rng.normal(size=(20, 3)).tolist()
    if rational:
        g.weights = rng.uniform(0.5, 2.0, 20).tolist()
    g.knotvector_u = [0, 0, 0, 0.4, 1, 1, 1]
    g.knotvector_v = [0, 0, 0, 0, 0.3, 1, 1, 1, 1]
    return g


@pytest.mark.parametrize("rational", [True, False])
def test_we_read_what_geomdl_writes(tmp_path, rational):
    g = _geomdl_surface(rational)
    path = tmp_path / "g.json"
    exchange.export_json(g, str(path))
    s = load_surface(path)
    assert s.rational == rational
    uv = np.random.default_rng(1).random((30, 2))
    ref = np.array(g.evaluate_list([tuple(x) for x in uv]))
    np.testing.assert_allclose(s.points(uv), ref, atol=1e-13)
    # v varies fastest in the point list: entry i * size_v + j is net point [i, j]
    np.testing.assert_array_equal(s.ctrlpts[1, 2], g.ctrlpts[1 * 5 + 2])


@pytest.mark.parametrize("name", example_names())
def test_bundled_examples_round_trip(tmp_path, name):
    s = load_surface(example_path(name))
    save_surface(s, tmp_path / "x.json")
    assert (tmp_path / "x.json").read_bytes() == example_path(name).read_bytes()


def _base_doc() -> dict:
    return json.loads(json.dumps(surface_to_json_dict(random_surface(np.random.default_rng(3)))))


def test_2d_points_are_read_as_z_zero():
    doc = _base_doc()
    rec = doc["shape"]["data"][0]
    rec["control_points"]["points"] = [p[:2] for p in rec["control_points"]["points"]]
    rec["dimension"] = 2
    s = surface_from_json_dict(doc)
    assert np.all(s.ctrlpts[..., 2] == 0.0)
    assert np.all(s.evaluate([[0.1, 0.2]]).normal[:, :2] == 0.0)


def test_tolerated_variants():
    doc = _base_doc()
    rec = doc["shape"]["data"][0]
    for key in ("count", "rational", "dimension", "type"):  # optional keys
        d = copy.deepcopy(doc)
        (d["shape"] if key == "count" else d["shape"]["data"][0]).pop(key)
        surface_from_json_dict(d)
    rec.update(degree_u=float(rec["degree_u"]), delta=[0.1, 0.1], name="x", id=3, reversed=True,
               trims={"count": 0, "data": []})
    surface_from_json_dict(doc)
    text = json.dumps(doc)
    parse_surface_json(text)
    parse_surface_json("\ufeff" + text)
    parse_surface_json(b"\xef\xbb\xbf" + text.encode())


def test_weights_only_when_rational():
    rng = np.random.default_rng(0)
    doc = surface_to_json_dict(random_surface(rng, rational=False))
    assert doc["shape"]["data"][0]["rational"] is False
    assert "weights" not in doc["shape"]["data"][0]["control_points"]
    doc = surface_to_json_dict(random_surface(rng, rational=True))
    assert doc["shape"]["data"][0]["rational"] is True
    assert len(doc["shape"]["data"][0]["control_points"]["weights"]) == \
        doc["shape"]["data"][0]["size_u"] * doc["shape"]["data"][0]["size_v"]


def test_source_label_and_type_errors():
    with pytest.raises(SurfaceError, match=r"^my label: "):
        surface_from_json_dict([], source="my label")
    with pytest.raises(TypeError):
        parse_surface_json(12)
    with pytest.raises(TypeError):
        save_surface("not a surface", "x.json")


# ---------------------------------------------------------------------- fuzzing
FUZZ_EXAMPLES = int(os.environ.get("FLATWEAVE_FUZZ_EXAMPLES", "0"))
FUZZ = settings(
    max_examples=FUZZ_EXAMPLES or 250,
    derandomize=not FUZZ_EXAMPLES,  # deterministic in CI; set the variable for a random, longer hunt
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.too_slow],
)

SPECIAL_FLOATS = [math.nan, math.inf, -math.inf, 0.0, -0.0, 1e-320, 1e300, -1e300, 1e101, 0.5, -1.0]
json_scalars = st.one_of(
    st.none(), st.booleans(),
    st.integers(min_value=-(10**20), max_value=10**20), st.sampled_from([0, 1, 2, 3, 4, -1, 10**400]),
    st.floats(allow_nan=True, allow_infinity=True), st.sampled_from(SPECIAL_FLOATS),
    st.text(max_size=8), st.sampled_from(["surface", "curve", "volume", "spline", "1", "NaN"]),
)
json_values = st.recursive(
    json_scalars,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner, max_size=3),
    max_leaves=12,
)

BASE_DOCS = [
    json.loads(json.dumps(surface_to_json_dict(random_surface(np.random.default_rng(s), rational=r))))
    for s, r in ((0, True), (1, False), (2, True))
]


def _paths(node, prefix=()):
    """Every (container path) to every value inside the JSON tree ``node``."""
    out = [prefix]
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _paths(v, prefix + (i,))
    return out


def _mutate(doc, data) -> None:
    """Apply one random mutation to ``doc`` in place, choosing with hypothesis ``data``."""
    paths = [p for p in _paths(doc) if p]
    if not paths:  # everything deleted already
        return
    path = data.draw(st.sampled_from(paths))
    parent = doc
    for k in path[:-1]:
        parent = parent[k]
    key = path[-1]
    action = data.draw(st.sampled_from(["replace", "delete", "scale", "duplicate", "add_key"]))
    if action == "replace":
        parent[key] = data.draw(json_values)
    elif action == "delete":
        del parent[key]
    elif action == "scale" and type(parent[key]) in (int, float):
        parent[key] = parent[key] * data.draw(st.sampled_from([-1, 0, 2, 0.5, 1e200, 1e-200]))
    elif action == "duplicate" and isinstance(parent, list):
        parent.insert(key, copy.deepcopy(parent[key]))
    elif action == "add_key" and isinstance(parent[key], dict):
        parent[key][data.draw(st.sampled_from(["weights", "count", "dimension", "trims", "x"]))] = \
            data.draw(json_values)


def _load_or_surface_error(fn, *args) -> None:
    """``fn(*args)`` must return a NurbsSurface or raise a one-line SurfaceError, warning-free."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            s = fn(*args)
        except SurfaceError as exc:
            assert_one_line(str(exc))
            return
        assert isinstance(s, NurbsSurface)
        back = parse_surface_json(dumps_surface(s))  # whatever we accept, we can write and read back
        assert_same_surface(s, back)


@pytest.mark.slow
@FUZZ
@given(data=st.data(), which=st.integers(0, len(BASE_DOCS) - 1), n=st.integers(1, 3))
def test_fuzz_mutated_documents(data, which, n):
    doc = copy.deepcopy(BASE_DOCS[which])
    for _ in range(n):
        _mutate(doc, data)
    _load_or_surface_error(surface_from_json_dict, doc, "fuzz")
    _load_or_surface_error(parse_surface_json, json.dumps(doc, allow_nan=True), "fuzz")


BASE_BYTES = [dumps_surface(surface_from_json_dict(d)).encode() for d in BASE_DOCS]


@pytest.mark.slow
@FUZZ
@given(data=st.data(), which=st.integers(0, len(BASE_BYTES) - 1))
def test_fuzz_damaged_bytes(data, which):
    raw = bytearray(BASE_BYTES[which])
    action = data.draw(st.sampled_from(["truncate", "flip", "insert", "delete", "garbage"]))
    if action == "truncate":
        raw = raw[: data.draw(st.integers(0, len(raw)))]
    elif action == "garbage":
        raw = bytearray(data.draw(st.binary(max_size=200)))
    else:
        for _ in range(data.draw(st.integers(1, 4))):
            i = data.draw(st.integers(0, max(len(raw) - 1, 0)))
            if action == "flip" and raw:
                raw[i] = data.draw(st.integers(0, 255))
            elif action == "insert":
                raw[i:i] = data.draw(st.binary(min_size=1, max_size=4))
            elif raw:
                del raw[i]
    _load_or_surface_error(parse_surface_json, bytes(raw), "fuzz")


@pytest.mark.slow
@FUZZ
@given(data=st.data())
def test_fuzz_json_values_anywhere(data):
    """Arbitrary JSON documents, and valid structure with arbitrary leaves."""
    _load_or_surface_error(surface_from_json_dict, data.draw(json_values), "fuzz")
    doc = copy.deepcopy(BASE_DOCS[0])
    rec = doc["shape"]["data"][0]
    key = data.draw(st.sampled_from(sorted(rec)))
    rec[key] = data.draw(json_values)
    _load_or_surface_error(surface_from_json_dict, doc, "fuzz")


def test_fuzz_files_on_disk(tmp_path):
    """The same contract through load_surface, for truncations of a real file."""
    raw = example_path("garment").read_bytes()
    for k, cut in enumerate(range(0, len(raw), max(1, len(raw) // 60))):
        path = tmp_path / f"cut{k}.json"
        path.write_bytes(raw[:cut])
        with pytest.raises(SurfaceError) as info:
            load_surface(path)
        assert_one_line(str(info.value))
