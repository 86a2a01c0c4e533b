"""The ASCII PLY reader's compiled fast path (cpp/include/zbuffer/ply_reader.h):
on every file it takes, read_ply gives what its line-by-line reading gives,
and it leaves everything else -- errors included -- to that reading."""

import glob
import io
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from zbuffer import _core, ply
from helpers import MODELS, model_path, spoil_a_line


def reading(tmp_path, raw, fast):
    """read_ply's data with the fast path (fast=True) or without it, or
    its error message."""
    path = tmp_path / "m.ply"
    path.write_bytes(raw)
    saved = ply._ascii_fast
    try:
        if not fast:
            ply._ascii_fast = lambda body, elements: None
        d = ply.read_ply(str(path))
    except ValueError as err:
        return f"{type(err).__name__}: {err}"
    finally:
        ply._ascii_fast = saved
    return d


def assert_same(fast, slow):
    if isinstance(fast, str) or isinstance(slow, str):
        assert fast == slow
        return
    for name in ["vertices", "polygon_sizes", "polygon_indices", "vertex_colors", "face_colors"]:
        got, expected = getattr(fast, name), getattr(slow, name)
        assert (got is None) == (expected is None), name
        if got is not None:
            np.testing.assert_array_equal(got, expected)
            assert got.dtype == expected.dtype and got.shape == expected.shape, name


def taken(raw):
    """Whether read_ply takes the file's records from the compiled reader's
    tables (ply._ascii_fast; True where it takes them and the properties'
    types refuse a value, as the line-by-line reading does too)."""
    fh = io.BytesIO(raw)
    _, elements = ply._header(fh)
    try:
        return ply._ascii_fast(fh.read(), elements) is not None
    except ValueError:  # (from _as_declared, on the tables it took)
        return True


numbers = st.one_of(st.floats(-10, 10).map(lambda x: f"{x:.6f}"), st.integers(-5, 5).map(str),
                    st.floats(allow_nan=False, allow_infinity=False, allow_subnormal=False)
                    .map(repr))
odd_words = st.sampled_from(["1e400", "inf", "nan", "0x10", "1_0", "abc", "1.5", "-1", "3.0",
                             "300", "1e", "é", "+2", "007", "2.5e0"])
endings = st.sampled_from(["\n", "\r\n", "\r", "\n\n"])


@st.composite
def ply_files(draw):
    """(plain, bytes): ASCII PLY files of vertices (float, double or int
    x y z, maybe uchar colours) and faces (a list of indices, maybe
    colours), maybe a third element, some with an odd word or line;
    `plain`: none odd, and every face of one size (each element's records
    as long as its first: the compiled reader's case)."""
    odd = draw(st.integers(0, 2)) == 0
    nv, nf = draw(st.integers(1, 6)), draw(st.integers(0, 5))
    xyz = draw(st.sampled_from(["float", "double", "int"]))
    vertex_rgb = draw(st.booleans())
    face_rgb = draw(st.booleans())
    sizes = [draw(st.sampled_from([3, 3, 4])) for _ in range(nf)]
    if draw(st.booleans()):  # all faces of one size: the compiled reader's case
        sizes = [sizes[0]] * nf if nf else sizes
    extra = draw(st.integers(0, 2))
    head = ["ply", "format ascii 1.0", "comment made by a test", f"element vertex {nv}"]
    head += [f"property {xyz} {c}" for c in "xyz"]
    if vertex_rgb:
        head += [f"property uchar {c}" for c in ("red", "green", "blue")]
    head += [f"element face {nf}", "property list uchar int vertex_indices"]
    if face_rgb:
        head += [f"property uchar {c}" for c in ("red", "green", "blue")]
    if extra:
        head += [f"element edge {extra}", "property int vertex1", "property int vertex2"]
    head.append("end_header")
    lines = []
    for _ in range(nv):
        words = [draw(st.integers(-5, 5).map(str)) if xyz == "int" else draw(numbers)
                 for _ in range(3)]
        if vertex_rgb:
            words += [str(draw(st.integers(0, 255))) for _ in range(3)]
        lines.append(" ".join(words))
    for n in sizes:
        words = [str(n)] + [str(draw(st.integers(0, nv - 1))) for _ in range(n)]
        if face_rgb:
            words += [str(draw(st.integers(0, 255))) for _ in range(3)]
        lines.append(draw(st.sampled_from([" ", "\t", "  "])).join(words))
    lines += [f"{draw(st.integers(0, nv - 1))} {draw(st.integers(0, nv - 1))}"
              for _ in range(extra)]
    if odd and lines:
        spoil_a_line(draw, lines, odd_words, ["", "   ", "\t", "1 2", "\x0c", "# 1 2 3"])
    text = "\n".join(head) + "\n" + "".join(line + draw(endings) for line in lines)
    return not odd and len(set(sizes)) <= 1, text.encode("utf-8")


@given(file=ply_files())
@settings(max_examples=300, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
def test_the_fast_path_reads_what_the_line_by_line_reading_reads(tmp_path, file):
    plain, raw = file
    fast, slow = reading(tmp_path, raw, True), reading(tmp_path, raw, False)
    assert_same(fast, slow)
    # A plain file is taken (else this test could pass by taking none).
    assert taken(raw) or not plain


def test_the_fast_path_takes_the_common_forms(tmp_path):
    # Not a test that cannot fail by taking nothing: a mesh of triangles
    # with colours, blank lines and \r\n line ends goes through it.
    raw = (b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
           b"property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
           b"element face 2\nproperty list uchar int vertex_indices\nend_header\n"
           b"0 0 0 255 0 0\r\n1 0 0 0 255 0\r\n\r\n1 1 0 0 0 255\r\n0 1 0.5 9 9 9\r\n"
           b"3 0 1 2\r\n3\t0 2 3\r\n  \r\n")
    assert taken(raw)
    fast = reading(tmp_path, raw, True)
    assert_same(fast, reading(tmp_path, raw, False))
    np.testing.assert_array_equal(fast.polygon_indices, [0, 1, 2, 0, 2, 3])
    np.testing.assert_array_equal(fast.vertices[3], [0, 1, 0.5])


@pytest.mark.parametrize("body, fast", [
    (b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n", False),  # more records than counted
    (b"0 0 0\n1 0 0\n0 1 0\n", False),                    # fewer
    (b"0 0 0\n1 0 0\n0 1\n3 0 1 2\n", False),             # a short record
    (b"0 0 0\n1 0 0\n0 1 inf\n3 0 1 2\n", False),         # not a plain number
    (b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2.5\n", False),         # a fraction for an index
    (b"0 0 0\n1 0 0\n0 1 0\n1e400 0 1 2\n", False),       # a list count of inf
    (b"0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", True),            # an index out of range
    (b"0 0 0\n1 0 0\n0 1 0 \xc3\xa9\n3 0 1 2\n", False),  # not ASCII
    (b"0 0 0\n1 0\x0c0 0\n0 1 0\n3 0 1 2\n", False),      # a form feed
])
def test_anything_else_reads_as_before(tmp_path, body, fast):
    # Read the same with and without the fast path: by the line-by-line
    # reading where the fast path leaves the file (an error of its own:
    # the index is checked after either reading).
    raw = (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
           b"property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
           b"end_header\n") + body
    assert taken(raw) == fast
    assert_same(reading(tmp_path, raw, True), reading(tmp_path, raw, False))


def _ascii_models():
    names = []
    for path in sorted(glob.glob(os.path.join(MODELS, "*.ply"))):
        with open(path, "rb") as fh:
            if b"format ascii" in fh.read(4096).split(b"end_header")[0]:
                names.append(os.path.basename(path))
    return names or ["bunny_16k.ply"]


@pytest.mark.models
@pytest.mark.parametrize("name", _ascii_models())
def test_ascii_models_go_the_fast_way_to_the_same_data(tmp_path, name):
    path = model_path(name)  # (skips without the models)
    raw = path.read_bytes()
    assert taken(raw)
    assert_same(reading(tmp_path, raw, True), reading(tmp_path, raw, False))


HEAD = (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        b"property float z\nelement face 1\nproperty list uchar int vertex_indices\n")


@pytest.mark.parametrize("raw, message", [
    # (the parity hunt's finds: a count past int64, an element named twice
    # whose records hold an error of their own, records shorter than the
    # properties)
    (HEAD.replace(b"vertex 3", b"vertex 9223372036854775808") + b"end_header\n0 0 0\n"
     b"1 0 0\n0 1 0\n3 0 1 2\n", "fewer records than its header declares"),
    (HEAD + b"element vertex 3\nproperty int x\nproperty float y\nproperty float z\n"
     b"end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n0 0 0\n0.5 0 0\n0 1 0\n",
     "two vertex elements"),
    (HEAD.replace(b"property float z\n", b"property float z\nproperty float w\n")
     + b"end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "malformed PLY record '0 0 0'"),
])
def test_errors_read_the_same_either_way(tmp_path, raw, message):
    fast, slow = reading(tmp_path, raw, True), reading(tmp_path, raw, False)
    assert_same(fast, slow)
    assert message in slow
