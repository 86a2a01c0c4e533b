"""PLY files with polygon faces (zbuffer/ply.py): kept as written, where
trimesh fans them (and fails on them with face colours)."""

import struct

import numpy as np
import pytest

import zbuffer
from helpers import MODELS

# A concave hexagon (an L) and a triangle, coloured per face.
VERTICES = [(0, 0, 0), (2, 0, 0), (2, 1, 0), (1, 1, 0), (1, 2, 0), (0, 2, 0), (3, 3, 1)]
FACES = [([0, 1, 2, 3, 4, 5], (255, 0, 0)), ([0, 1, 6], (0, 128, 255))]


def header(fmt, face_props="property uchar red\nproperty uchar green\nproperty uchar blue\n"):
    return (f"ply\nformat {fmt} 1.0\ncomment an L and a triangle\nelement vertex 7\n"
            "property float x\nproperty float y\nproperty float z\nelement face 2\n"
            f"property list uchar int vertex_indices\n{face_props}end_header\n").encode()


def ascii_ply():
    return header("ascii") + "".join(f"{x} {y} {z}\n" for x, y, z in VERTICES).encode() + \
        "".join(f"{len(f)} {' '.join(map(str, f))} {r} {g} {b}\n"
                for f, (r, g, b) in FACES).encode()


def binary_ply(order):
    fmt = "binary_little_endian" if order == "<" else "binary_big_endian"
    return header(fmt) + b"".join(struct.pack(order + "3f", *v) for v in VERTICES) + \
        b"".join(struct.pack(f"{order}B{len(f)}i3B", len(f), *f, *c) for f, c in FACES)


@pytest.mark.parametrize("kind", ["ascii", "<", ">"])
def test_polygons_are_kept_and_triangulated_exactly(tmp_path, kind):
    path = tmp_path / "l.ply"
    path.write_bytes(ascii_ply() if kind == "ascii" else binary_ply(kind))
    mesh = zbuffer.load(path, merge_vertices=False)
    assert mesh.polygon_sizes.tolist() == [6, 3]
    assert mesh.face_polygon.tolist() == [0, 0, 0, 0, 1]
    tri = mesh.vertices[mesh.faces[:4]]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    assert area.sum() == pytest.approx(3.0)  # the L's area (a fan would cover 4)
    np.testing.assert_allclose(mesh.face_colors, [[1, 0, 0]] * 4 + [[0, 128 / 255, 1]],
                               rtol=1e-6)
    obj = tmp_path / "l.obj"
    obj.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in VERTICES) + "f 1 2 3 4 5 6\nf 1 2 7\n")
    np.testing.assert_array_equal(zbuffer.load(obj).faces, mesh.faces)
    cam = zbuffer.Camera.look_at((1, 1, 4), (1, 1, 0))
    scan = zbuffer.render(mesh, algo="scanline", camera=cam, width=48, height=48, shading="none")
    ref = zbuffer.reference.render(mesh, camera=cam, width=48, height=48, shading="none",
                                   polygons=True)
    np.testing.assert_array_equal(scan.triangle_id, ref.triangle_id)
    plain = zbuffer.render(mesh, algo="zbuffer", camera=cam, width=48, height=48, shading="none")
    np.testing.assert_array_equal(scan.mask, plain.mask)


def test_other_properties_are_skipped(tmp_path):
    # A list before the indices, float vertex colours, a face property
    # after them, and an element between the vertices and the faces.
    text = ("ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\nproperty double y\n"
            "property double z\nproperty float red\nproperty float green\nproperty float blue\n"
            "element material 1\nproperty int id\n"
            "element face 1\nproperty list uchar float texcoord\n"
            "property list uchar int vertex_indices\nproperty int flags\nend_header\n"
            "0 0 0 1 0 0\n1 0 0 0 1 0\n1 1 0 0 0 1\n0 1 0 1 1 1\n7\n"
            "8 0 0 1 0 1 1 0 1 4 0 1 2 3 5\n")
    path = tmp_path / "quad.ply"
    path.write_text(text)
    mesh = zbuffer.load(path, merge_vertices=False)
    assert mesh.polygon_sizes.tolist() == [4]
    assert mesh.faces.tolist() == [[0, 1, 2], [0, 2, 3]]
    np.testing.assert_allclose(mesh.vertex_colors, [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]])


def test_bad_polygon_files_are_refused(tmp_path):
    from zbuffer.ply import read_ply

    path = tmp_path / "bad.ply"
    data = ascii_ply().replace(b"6 0 1 2 3 4 5", b"6 0 1 2 3 4 9")
    path.write_bytes(data)
    with pytest.raises(ValueError, match="could not read a mesh from"):
        zbuffer.load(path)
    path.write_bytes(ascii_ply().replace(b"6 0 1 2 3 4 5", b"6 0 1 2.5 3 4 5"))
    with pytest.raises(ValueError, match="malformed PLY record '6 0 1 2.5 3 4 5"):
        read_ply(path)
    path.write_bytes(binary_ply("<")[:-5])
    with pytest.raises(ValueError, match="fewer records than its header declares"):
        read_ply(path)


def test_vertex_and_face_colours_together_keep_the_vertices(tmp_path):
    text = ascii_ply().decode().replace(
        "property float z\n", "property float z\nproperty uchar red\nproperty uchar green\n"
        "property uchar blue\n").replace("0 0 0\n", "0 0 0 10 20 30\n", 1)
    lines = text.split("end_header\n")
    body = lines[1].splitlines()
    body = [line if line.count(" ") == 5 else line + " 255 255 255" for line in body[:7]] + body[7:]
    path = tmp_path / "both.ply"
    path.write_text(lines[0] + "end_header\n" + "\n".join(body) + "\n")
    mesh = zbuffer.load(path, merge_vertices=False)
    assert mesh.face_colors is None
    np.testing.assert_allclose(mesh.vertex_colors[0], [10 / 255, 20 / 255, 30 / 255], rtol=1e-6)


@pytest.mark.parametrize("change, message", [
    # A face of no corners and one of two: trimesh dropped them, and fanned the quad.
    ((b"3 0 1 6 0 128 255", b"0"), "malformed PLY record '0'"),
    ((b"3 0 1 6", b"2 0 1"), "face has fewer than 3 corners"),
    ((b"element face 2", b"element face -2"), "element count must be a whole number"),
    ((b"element face 2", b"element face 4000000000"), "fewer records than its header declares"),
    ((b"element face 2", b"element face 1"), "more records than its header declares"),
    ((b"0 128 255", b"0 300 255"), "face colours must lie in 0-255"),
    # A fuzzer's finds: an index past int64 (an OverflowError), a record
    # longer than its properties and a colour of 2.5 (both read as if fine),
    # a list counted by a float (numpy's "invalid shape").
    ((b"3 0 1 6", b"3 0 1 9223372036854775808"), "a face index lies outside [0, 7)"),
    ((b"0 128 255", b"0 128 255 7"), "malformed PLY record '3 0 1 6 0 128 255 7'"),
    ((b"5 255 0 0", b"5 255 2.5 0"), "property 'green' has an integer type, but a record holds 2.5"),
    ((b"list uchar int", b"list float int"), "a list's count must have an integer type"),
    # a float property's text beyond float32 (numpy's overflow warning, then
    # "a NaN or infinite coordinate" for a finite number)
    ((b"\n3 3 1\n", b"\n3 1e39 1\n"),
     "property 'y' is a float (32-bit), but a record holds 1e+39, beyond its range"),
])
@pytest.mark.filterwarnings("error")
def test_malformed_files_are_refused_plainly(tmp_path, change, message):
    path = tmp_path / "bad.ply"
    data = ascii_ply()
    assert change[0] in data
    path.write_bytes(data.replace(*change))
    with pytest.raises(ValueError, match="could not read a mesh from") as err:
        zbuffer.load(path)
    assert message in str(err.value)


@pytest.mark.parametrize("index, message", [(2.5, "a face index is not a whole number: 2.5"),
                                            (float("inf"), "not a whole number: inf"),
                                            (1e300, "a face index lies outside [0, 7)")])
def test_face_indices_of_a_float_type_must_be_whole_and_in_range(tmp_path, index, message):
    # (They were truncated to integers, or raised OverflowError.)
    path = tmp_path / "float_indices.ply"
    faces = [([0, 1, 2, 3, 4, 5], ()), ([0, 1, index], ())]
    data = header("binary_little_endian", "").replace(b"list uchar int", b"list uchar double") \
        + b"".join(struct.pack("<3f", *v) for v in VERTICES) \
        + b"".join(struct.pack(f"<B{len(f)}d", len(f), *f) for f, _ in faces)
    path.write_bytes(data)
    with pytest.raises(ValueError, match="could not read a mesh from") as err:
        zbuffer.load(path)
    assert message in str(err.value)
    path.write_bytes(data.replace(struct.pack("<d", index), struct.pack("<d", 6.0)))
    assert len(zbuffer.load(path).faces) == 5


@pytest.mark.parametrize("index, message", [("9223372036854775808", "a face index lies outside"),
                                            ("9" * 400, "a face index lies outside"),
                                            ("inf", "malformed PLY record '3 0 1 inf")])
def test_huge_indices_in_a_file_of_triangles_are_named(tmp_path, index, message):
    # (All faces of one size are read at once, as floats: such an index made
    # numpy warn of an invalid cast before the range check refused it.)
    path = tmp_path / "triangles.ply"
    path.write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                    "property float y\nproperty float z\nelement face 2\n"
                    "property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
                    f"3 0 1 2\n3 0 1 {index}\n")
    with pytest.raises(ValueError, match="could not read a mesh from") as err:
        zbuffer.load(path)
    assert message in str(err.value)


def test_a_negative_list_count_is_named(tmp_path):
    # (A char count of -3 read as "fewer records than its header declares".)
    path = tmp_path / "negative.ply"
    data = header("binary_little_endian", "").replace(b"list uchar int", b"list char int") \
        + b"".join(struct.pack("<3f", *v) for v in VERTICES) \
        + struct.pack("<b6i", 6, 0, 1, 2, 3, 4, 5) + struct.pack("<b3i", -3, 0, 1, 6)
    path.write_bytes(data)
    with pytest.raises(ValueError, match="record 1 of an element has a list of -3 items"):
        zbuffer.load(path)


def test_binary_data_beyond_the_counts_is_refused(tmp_path):
    path = tmp_path / "more.ply"
    path.write_bytes(binary_ply("<").replace(b"element face 2", b"element face 1"))
    with pytest.raises(ValueError, match="more records than its header declares"):
        zbuffer.load(path)
    path.write_bytes(binary_ply("<") + b"\n")  # (a line end after the data: fine)
    assert len(zbuffer.load(path).faces) == 5


def test_huge_counts_are_refused_before_anything_of_their_size(tmp_path):
    # (The records the counts promise would take tens of GB.)
    path = tmp_path / "huge.ply"
    for order in "<>":
        path.write_bytes(binary_ply(order).replace(b"element face 2", b"element face 4000000000"))
        with pytest.raises(ValueError, match="fewer records than its header declares"):
            zbuffer.load(path)


@pytest.mark.skipif(not (MODELS / "bunny_16k.ply").is_file(), reason="shared models not present")
def test_a_triangle_file_reads_as_trimesh_reads_it():
    import trimesh

    mesh = zbuffer.load(MODELS / "bunny_16k.ply", merge_vertices=False)
    tm = trimesh.load(MODELS / "bunny_16k.ply", force="mesh", process=False)
    assert mesh.polygon_sizes is None
    np.testing.assert_array_equal(mesh.faces, tm.faces)
    np.testing.assert_array_equal(mesh.vertices, tm.vertices)
