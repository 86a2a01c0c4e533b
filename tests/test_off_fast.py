"""The ASCII OFF reader's compiled fast path (cpp/include/zbuffer/off_reader.h):
on every file it takes it gives what the Python reader gives, and it leaves
everything else -- errors included -- to that reader."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from zbuffer import _core
from zbuffer.off import _off_data, _read_off_text, read_off
from helpers import assert_fast_path_agrees, model_names, model_path, spoil_a_line


def python_reading(raw):
    """The Python reader's data, or its error message."""
    try:
        return _read_off_text(raw.decode("utf-8", errors="replace"))
    except ValueError as err:
        return str(err)


def fast_reading(raw):
    """The fast path's data as read_off makes it (_off_data), its error
    message, or None where it leaves the file."""
    fast = _core.read_off_records(raw)
    if fast is None:
        return None
    try:
        d = _off_data(fast)
    except ValueError as err:
        return str(err)
    return d.vertices, d.polygon_sizes, d.polygon_indices, d.vertex_colors, d.face_colors


def assert_same(fast, slow):
    if isinstance(fast, str) or isinstance(slow, str):
        assert fast == slow
        return
    vertices, sizes, indices, vertex_colors, face_colors = fast
    for got, expected in [(vertices, slow.vertices), (sizes, slow.polygon_sizes),
                          (indices, slow.polygon_indices)]:
        np.testing.assert_array_equal(got, expected)
        assert got.dtype == expected.dtype and got.shape == expected.shape
    for got, expected in [(vertex_colors, slow.vertex_colors), (face_colors, slow.face_colors)]:
        assert (got is None) == (expected is None)
        if got is not None:
            np.testing.assert_array_equal(got, expected)


odd_words = st.sampled_from([
    "1.", ".5", "-.5", "+2", "+.5e-3", "1E+05", "1e", ".", "-", "1e400", "1e-400", "4e-320",
    "inf", "nan", "0x10", "1_0", "0", "-0", "0012.50", "255", "256", "1,5", "e5", "abc", "#",
    "+3", "-1", "03", "9"])
numbers = st.one_of(st.floats(-10, 10).map(lambda x: f"{x:.6f}"),
                    st.floats(allow_nan=False, allow_infinity=False, allow_subnormal=False)
                    .map(repr),
                    st.integers(-5, 5).map(str))
integer_colours = st.integers(0, 255).map(str)
float_colours = st.one_of(st.floats(0, 1).map(lambda x: f"{x:.3f}"), st.sampled_from(["1e-1", "1."]))
any_colours = st.one_of(integer_colours, float_colours,
                        st.sampled_from(["1e-1", "0", "1", "255", "256", "1.5"]))
blank = st.sampled_from([" ", "  ", "\t"])
endings = st.sampled_from(["\n", "\r\n", "\r", "\n\n"])


@st.composite
def off_files(draw):
    """(clean, the file's bytes): OFF files, mostly well formed -- a header
    and counts, vertices and faces of the header's kind -- sometimes (not
    `clean`) with an odd word, line or count."""
    odd = draw(st.integers(0, 2)) == 0
    header = draw(st.sampled_from(["OFF", "COFF", "NOFF", "CNOFF"]))
    nv, nf = draw(st.integers(0, 6)), draw(st.integers(0, 6))
    if nv == 0:
        nf = 0
    counts = [str(nv), str(nf), str(draw(st.integers(0, 9)))]
    if odd and draw(st.booleans()):
        counts[draw(st.integers(0, 2))] = draw(odd_words)
    lines = ["# comment"] if draw(st.booleans()) else []
    lines += [draw(st.sampled_from([header + " ", header, header + "\n"])) + " ".join(counts)]
    alpha = draw(st.booleans())
    colour_numbers = draw(st.sampled_from([integer_colours, float_colours, any_colours]))
    for _ in range(nv):
        words = draw(st.lists(numbers, min_size=3, max_size=3))
        if header in ("NOFF", "CNOFF"):
            words += draw(st.lists(numbers, min_size=3, max_size=3))
        if header in ("COFF", "CNOFF"):
            words += draw(st.lists(colour_numbers, min_size=3 + alpha, max_size=3 + alpha))
        lines.append(draw(blank).join(words))
    face_colours = draw(st.sampled_from(["none", "rgb", "rgba", "index", "mixed"]))
    for _ in range(nf):
        n = draw(st.sampled_from([3, 3, 4, 5, 24]))
        words = [str(n)] + [str(draw(st.integers(0, max(nv - 1, 0)))) for _ in range(n)]
        kind = draw(st.sampled_from(["none", "rgb", "rgba", "index"])) \
            if face_colours == "mixed" else face_colours
        if kind in ("rgb", "rgba"):
            words += draw(st.lists(colour_numbers, min_size=3 + (kind == "rgba"),
                                   max_size=3 + (kind == "rgba")))
        elif kind == "index":
            words.append(str(draw(st.integers(0, 9))))
        lines.append(draw(blank).join(words) + (" # note" if draw(st.integers(0, 4)) == 0 else ""))
    if odd and lines:
        spoil_a_line(draw, lines, odd_words, [
            "\x0c1 2 3", "# é", "é", "1\x0b2", "_", "OFF BINARY", "   ", "3 0 1 2 3 4"])
    text = "".join(line + draw(endings) for line in lines)
    if draw(st.integers(0, 9)) == 0:
        text = "\ufeff" + text
    return not odd, text.encode("utf-8")


@given(file=off_files())
@settings(max_examples=500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_the_fast_path_reads_what_the_python_reader_reads(file):
    clean, raw = file
    assert_fast_path_agrees(fast_reading(raw), python_reading(raw), clean, raw, assert_same)


def test_the_fast_path_takes_the_common_forms():
    # Not a test that cannot fail by taking nothing: files in the forms
    # tools write go through it, colours and all.
    for text in ["OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n",
                 "\ufeff# made by hand\r\nCOFF 3 1 3\r\n0 0 0 255 0 0\r\n1 0 0 0 255 0 255\r\n"
                 "0 1 0 0 0 255\r\n3 0 1 2 0.5 0.25 1.0\r\n",
                 "NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2 7\n"]:
        raw = text.encode()
        fast = fast_reading(raw)
        assert fast is not None and not isinstance(fast, str), text
        assert_same(fast, python_reading(raw))
    _, _, _, vertex_colors, face_colors = fast_reading(
        b"COFF 3 1 3\n0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0 0 0 255\n3 0 1 2 0.5 0.25 1.0\n")
    np.testing.assert_array_equal(vertex_colors, np.eye(3))
    np.testing.assert_array_equal(face_colors, [[0.5, 0.25, 1.0]])
    # Colours are floats (0-1) when any of their numbers, alpha included,
    # has a point or an exponent.
    raw = b"COFF 3 1 3\n0 0 0 1 0 0 0.5\n1 0 0 0 1 0 1\n0 1 0 0 0 1 1\n3 0 1 2 1 1 0 1e0\n"
    _, _, _, vertex_colors, face_colors = fast_reading(raw)
    np.testing.assert_array_equal(vertex_colors, np.eye(3))
    np.testing.assert_array_equal(face_colors, [[1, 1, 0]])
    assert_same(fast_reading(raw), python_reading(raw))


@pytest.mark.parametrize("change", [
    ("0 0 0\n", "inf 0 0\n"), ("0 0 0\n", "0 0 0 # é\n"), ("0 0 0\n", "0_0 0 0\n"),
    ("4 2 0", "4 3 0"), ("4 2 0", "5 2 0"), ("3 0 1 2\n", "3 0 1 4\n"), ("3 0 1 2\n", "2 0 1\n"),
    ("3 0 1 2\n", "3 0 1 2 9 9\n"), ("3 0 1 2\n", "3 0 1 -1\n"), ("OFF", "OFF BINARY"),
    ("OFF", "COFF"), ("3 0 1 2\n", "3 0 1 2 inf\n"), ("1 1 0\n", "1 1\x0c0\n"),
    ("3 0 1 2\n", "3 0 1 " + "0" * 4300 + "2\n")])  # (int() refuses over 4300 digits)
def test_anything_else_is_left_to_the_python_reader(tmp_path, change):
    text = "OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n"
    raw = text.replace(*change, 1).encode()
    assert _core.read_off_records(raw) is None
    path = tmp_path / "a.off"
    path.write_bytes(raw)
    slow = python_reading(raw)
    if isinstance(slow, str):
        with pytest.raises(ValueError) as err:
            read_off(str(path))
        assert str(err.value) == slow
    else:
        got = read_off(str(path))
        np.testing.assert_array_equal(got.vertices, slow.vertices)
        np.testing.assert_array_equal(got.polygon_indices, slow.polygon_indices)


def test_counts_beyond_what_the_file_can_hold_are_left_to_the_python_reader():
    # A header counting more records than the file's bytes could hold is
    # refused before anything is reserved for them (a lying count of 20
    # million vertices in a small file asked for 480 MB).
    raw = b"OFF 20000000 0 0\n" + b"# padding\n" * 1000 + b"0 0 0\n"
    assert _core.read_off_records(raw) is None
    assert "header counts 20000000 vertices" in python_reading(raw)


@pytest.mark.models
@pytest.mark.parametrize("name", model_names(".off", "bunny_7k.off"))
def test_every_model_goes_the_fast_way_to_the_same_data(name):
    path = model_path(name)  # (skips without the models)
    with open(path, "rb") as fh:
        raw = fh.read()
    fast = fast_reading(raw)
    assert fast is not None
    assert_same(fast, python_reading(raw))
