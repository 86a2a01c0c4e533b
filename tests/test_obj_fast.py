"""The OBJ reader's compiled fast path (cpp/include/zbuffer/obj_reader.h):
on every file it takes it gives what the Python reader gives, and it leaves
everything else -- errors included -- to that reader."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from zbuffer import _core
from zbuffer.obj import _read_obj_text, _unit_colors, read_obj
from helpers import assert_fast_path_agrees, model_names, model_path


def python_reading(raw):
    """The Python reader's data, or its error message."""
    try:
        d = _read_obj_text(raw.decode("utf-8", errors="replace"))
    except ValueError as err:
        return str(err)
    return d


def assert_same(fast, slow):
    vertices, colors, sizes, indices = fast
    assert not isinstance(slow, str), f"the fast path took a file the Python reader refuses: {slow}"
    np.testing.assert_array_equal(vertices, slow.vertices)
    assert vertices.dtype == slow.vertices.dtype and vertices.shape == slow.vertices.shape
    np.testing.assert_array_equal(sizes, slow.polygon_sizes)
    np.testing.assert_array_equal(indices, slow.polygon_indices)
    assert sizes.dtype == np.int64 and indices.dtype == np.int64
    if slow.vertex_colors is None:
        assert colors is None
    else:
        np.testing.assert_array_equal(_unit_colors(colors), slow.vertex_colors)


# Words a record may hold: mostly numbers and corners of the common forms
# (so that many files are taken), sometimes ones outside them, and junk.
odd_numbers = st.sampled_from([
    "1.", ".5", "-.5", "+2", "+.5e-3", "1E+05", "1e", ".", "-", "1e400", "1e-400", "4e-320",
    "inf", "-Infinity", "nan", "0x10", "1_0", "0", "-0", "00012.50", "255", "256", "1,5",
    "1.5.2", "e5", "1e5e5", "\u0663"])
numbers = st.one_of(
    st.floats(allow_nan=False, allow_infinity=False, allow_subnormal=False).map(repr),
    st.floats(allow_nan=False, allow_infinity=False).map(repr),
    st.floats(-10, 10).map(lambda x: f"{x:.6f}"),
    st.integers(-300, 300).map(str),
    odd_numbers)
suffixes = st.sampled_from(["", "", "/1", "//2", "/3/4", "/", "/x", "/_"])
corners = st.one_of(
    st.tuples(st.sampled_from([1, 2, 3, -1, -2, -3]), suffixes).map(lambda t: f"{t[0]}{t[1]}"),
    st.tuples(st.integers(-12, 12), suffixes).map(lambda t: f"{t[0]}{t[1]}"),
    st.sampled_from(["+3", "003", "2147483649", "-2147483649", "/1", "a", "1a", "--1"]))
blank = st.sampled_from([" ", "  ", "\t", " \t "])
endings = st.sampled_from(["\n", "\r\n", "\r", "\n\n"])


in_range = st.tuples(st.sampled_from([1, 2, 3, -1, -2, -3]),
                     suffixes.filter(lambda w: "_" not in w)).map(
    lambda t: f"{t[0]}{t[1]}")


@st.composite
def records(draw, clean=False, colored=False):
    """One record line: with `clean`, of the common forms only (`colored`:
    its v records have colours)."""
    kinds = ["v", "v", "f", "f", "other"] if clean else ["v", "v", "v", "vc", "f", "f", "other",
                                                        "odd"]
    kind = draw(st.sampled_from(kinds))
    if kind == "v" and colored:
        kind = "vc"
    sep = draw(blank)
    if kind in ("v", "vc"):
        count = draw(st.sampled_from([3, 3, 3, 4, 6] if kind == "v" else [6]))
        if draw(st.integers(0, 9)) == 0 and not clean:
            count = draw(st.integers(0, 8))
        odd = not clean and draw(st.integers(0, 4)) == 0
        words = ["v"] + draw(st.lists(numbers if odd else numbers.filter(plain),
                                      min_size=count, max_size=count))
        if kind == "vc":
            words[4:7] = [str(draw(st.integers(0, 255))) for _ in range(3)]
    elif kind == "f":
        size = draw(st.sampled_from([2, 3, 3, 3, 4, 5]))
        words = ["f"] + draw(st.lists(in_range if clean else corners, min_size=size,
                                      max_size=size))
        if clean and size == 2:
            words.append("1")
    elif kind == "other":
        words = [draw(st.sampled_from(["vt", "vn", "vp", "fo", "g", "o", "usemtl", "s", "#",
                                       "mtllib", "l"]))] + draw(
            st.lists(numbers.filter(plain) if clean else numbers, max_size=3))
    else:
        return draw(st.sampled_from([
            "", "   ", "# comment \\", "v 1 2 3 \\", "f 1 2 \\", "v 1 2 3 # c", "\x0cv 1 2 3",
            "\u00a0v 1 2 3", "v 1\x0b2 3", "v\t1\t2\t3", "é", "v 1 2 3 é", "# é", "\x1cf 1 2 3",
            "f 1 2 3 # x \\", "v# 1 2 3", "f", "v", "vv 1 2 3", "f1 2 3", "\ufeffv 1 2 3"]))
    line = sep.join(words)
    if draw(st.booleans()):
        line = draw(blank) + line
    if draw(st.integers(0, 5)) == 0:
        line += " # " + draw(st.sampled_from(["note", "f 1 2 3", "é", "\\"]))
    return line


def plain(word):
    if "e-3" in word and abs(float(word)) < 2.2250738585072014e-308:
        return False  # (subnormal: left to Python)
    return word not in ("1e400", "1e-400", "4e-320", "inf", "-Infinity", "nan", "0x10",
                        "1_0", "1,5", "1.5.2", "e5", "1e5e5", "\u0663", "1e", ".", "-")


@st.composite
def obj_files(draw):
    """(clean, the file's bytes): `clean` files hold only the forms the fast
    path takes."""
    clean = draw(st.booleans())
    colored = clean and draw(st.integers(0, 3)) == 0
    lines = draw(st.lists(records(clean, colored), max_size=14))
    if draw(st.integers(0, 4)):  # three vertices for the faces to use
        rgb = " 0 128 255" if colored else ""
        lines = [f"v 0 0 0{rgb}", f"v 1 0 0{rgb}", f"v 0 1 0{rgb}"] + lines
    text = "".join(line + draw(endings) for line in lines)
    if draw(st.integers(0, 9)) == 0:
        text = "\ufeff" + text
    data = text.encode("utf-8")
    if not clean and draw(st.integers(0, 9)) == 0:
        data += b"\xff\xfe# broken utf-8\n"
    return clean, data


@given(file=obj_files())
@settings(max_examples=600, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_the_fast_path_reads_what_the_python_reader_reads(file):
    clean, raw = file
    assert_fast_path_agrees(_core.read_obj_records(raw), python_reading(raw), clean, raw,
                            assert_same)


def test_the_fast_path_takes_the_common_forms():
    # Not a test that cannot fail by taking nothing: these files, in the
    # forms exporters write, go through it.
    raw = (b"\xef\xbb\xbf# exported\r\nmtllib a.mtl\r\no thing\r\n"
           b"v 0 0 0\r\nv 1.5 -2e-3 +3\r\n  v\t.5 5. 1E+2 1\r\nvt 0 1\r\nvn 0 0 1\r\n"
           b"v 1 1 1 # a comment\r\ng side\r\nusemtl red\r\ns off\r\n"
           b"f 1/1/1 2/1/1 3/1/1\r\nf -4//1 -3//1 -2//1 -1//1\r\nf 1 2 4 # quad? no\r\n")
    fast = _core.read_obj_records(raw)
    assert fast is not None
    assert_same(fast, python_reading(raw))
    vertices, colors, sizes, indices = fast
    np.testing.assert_array_equal(vertices[3], [1, 1, 1])
    assert colors is None and list(sizes) == [3, 4, 3]
    np.testing.assert_array_equal(indices, [0, 1, 2, 0, 1, 2, 3, 0, 1, 3])
    coloured = b"v 0 0 0 255 0 0\nv 1 0 0 0 255 0\nv 0 1 0 0 0 51\nf 1 2 3\n"
    fast = _core.read_obj_records(coloured)
    assert fast is not None and fast[1] is not None
    assert_same(fast, python_reading(coloured))
    # a fraction above 1 among the colours: the Python reader's error
    assert _core.read_obj_records(coloured.replace(b"51", b"1.5")) is None
    assert isinstance(python_reading(coloured.replace(b"51", b"1.5")), str)


@pytest.mark.parametrize("line", [
    "v 1 2 3 \\\n4", "v inf 0 0", "v nan 0 0", "v 1e400 0 0", "v 1_0 0 0", "v 0x10 0 0",
    "\x0cv 1 2 3", "\u00a0v 5 5 5", "v 1\x0b2 3", "v 1 2", "v 1 2 3 4 5", "f 1 2", "f 1 0 2",
    "f 1 2 9", "f 1 a 2", "vt 0_5 1",
    "f " + "0" * 4300 + "1 2 3"])  # (int() refuses over 4300 digits)
def test_anything_else_is_left_to_the_python_reader(tmp_path, line):
    # Lines the fast path does not take: read_obj gives the Python reader's
    # data, or raises its error (naming the line).
    raw = ("v 0 0 0\nv 1 0 0\nv 0 1 0\n" + line + "\nf 1 2 3\n").encode()
    assert _core.read_obj_records(raw) is None
    path = tmp_path / "a.obj"
    path.write_bytes(raw)
    slow = python_reading(raw)
    if isinstance(slow, str):
        with pytest.raises(ValueError, match="^line 4: "):
            read_obj(str(path))
    else:
        got = read_obj(str(path))
        np.testing.assert_array_equal(got.vertices, slow.vertices)
        np.testing.assert_array_equal(got.polygon_indices, slow.polygon_indices)


@pytest.mark.models
@pytest.mark.parametrize("name", model_names(".obj", "bunny_10k.obj"))
def test_every_model_goes_the_fast_way_to_the_same_data(name):
    path = model_path(name)  # (skips without the models)
    with open(path, "rb") as fh:
        raw = fh.read()
    fast = _core.read_obj_records(raw)
    assert fast is not None
    assert_same(fast, python_reading(raw))
