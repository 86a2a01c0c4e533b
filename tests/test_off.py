"""The OFF reader (zbuffer/off.py): polygon faces kept as written, colours,
and malformed files refused with the line named."""

import numpy as np
import pytest

import zbuffer
from helpers import MODELS
from zbuffer.off import read_off

# A concave hexagon (an L) and a triangle, with face colours.
CONCAVE = """OFF
# an L and a triangle
7 2 0
0 0 0
2 0 0
2 1 0
1 1 0
1 2 0
0 2 0   # the last corner of the L
3 3 1
6  0 1 2 3 4 5  255 0 0
3  0 1 6  0 128 255
"""


def write(tmp_path, text, name="m.off"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_concave_polygons_are_kept_and_triangulated_exactly(tmp_path):
    mesh = zbuffer.load(write(tmp_path, CONCAVE), merge_vertices=False)
    assert mesh.polygon_sizes.tolist() == [6, 3]
    assert mesh.polygon_indices.tolist() == [0, 1, 2, 3, 4, 5, 0, 1, 6]
    assert mesh.face_polygon.tolist() == [0, 0, 0, 0, 1]
    # The L's triangles cover its area (3), where a fan from corner 0 would
    # cover the notch too (4).
    tri = mesh.vertices[mesh.faces[:4]]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    assert area.sum() == pytest.approx(3.0)
    np.testing.assert_allclose(mesh.face_colors, [[1, 0, 0]] * 4 + [[0, 128 / 255, 1]],
                               rtol=1e-6)
    # The same as the OBJ reader makes of the same polygons.
    obj = "".join(f"v {x} {y} {z}\n" for x, y, z in mesh.vertices) + \
        "f 1 2 3 4 5 6\nf 1 2 7\n"
    same = zbuffer.load(write(tmp_path, obj, "m.obj"))
    np.testing.assert_array_equal(same.faces, mesh.faces)
    # Scanline (the polygons as written) and the others (the triangles)
    # cover the same pixels.
    cam = zbuffer.Camera.look_at((1, 1, 4), (1, 1, 0))
    scan = zbuffer.render(mesh, algo="scanline", camera=cam, width=48, height=48, shading="none")
    plain = zbuffer.render(mesh, algo="zbuffer", camera=cam, width=48, height=48, shading="none")
    np.testing.assert_array_equal(scan.mask, plain.mask)
    ref = zbuffer.reference.render(mesh, camera=cam, width=48, height=48, shading="none",
                                   polygons=True)
    np.testing.assert_array_equal(scan.triangle_id, ref.triangle_id)
    np.testing.assert_array_equal(scan.depth, ref.depth)


def test_vertex_and_face_colours_together_keep_the_vertices(tmp_path):
    mesh = zbuffer.load(write(tmp_path, "COFF\n4 1 0\n0 0 0 255 0 0\n1 0 0 0 255 0\n"
                                        "1 1 0 0 0 255\n0 1 0 9 9 9\n4 0 1 2 3 10 20 30\n"),
                        merge_vertices=False)
    assert mesh.face_colors is None and mesh.polygon_sizes.tolist() == [4]
    np.testing.assert_allclose(mesh.vertex_colors[:3], np.eye(3))


def test_header_variants_colours_and_comments(tmp_path):
    # Counts on the header's line, COFF vertex colours (floats), NOFF
    # normals (skipped), comments anywhere, faces without colours.
    data = read_off(write(tmp_path, "COFF 3 1 0\n0 0 0 1 0 0 1\n1 0 0 0 1 0 1\n"
                                    "0 1 0 0 0 1.0 1\n3 0 1 2\n"))
    np.testing.assert_array_equal(data.vertex_colors, np.eye(3))
    assert data.face_colors is None
    data = read_off(write(tmp_path, "NOFF\n# counts next\n3 1 3\n0 0 0 0 0 1\n1 0 0 0 0 1\n"
                                    "0 1 0 0 0 1 # a normal\n3 0 1 2 0.5 0.5 0.5 1.0\n"))
    np.testing.assert_array_equal(data.vertices, [[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    np.testing.assert_array_equal(data.face_colors, [[0.5, 0.5, 0.5]])
    assert data.vertex_colors is None


@pytest.mark.parametrize("text, message", [
    ("OFF\n3 1 0\n0 0 0\n1 0 0\n3 0 1 2\n", "counts 3 vertices and 1 faces"),
    ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "line 6: face index outside"),
    ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "line 6: bad face record"),
    ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1\n3 0 1 2\n", "line 5: a vertex needs 3 numbers"),
    ("OFF\n3 1 0\n0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n", "non-numeric coordinate"),
    ("OFF\n3 1 0\n0 0 0\n1 1_0 0\n0 1 0\n3 0 1 2\n", "line 4: a number may hold only ASCII"),
    ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n", "line 7: more records"),
    ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 300 0 0\n", "face colours must lie in 0-255"),
    ("OFF\nthree 1 0\n", "line 2: expected the vertex, face and edge counts"),
    ("OFF\n" + "0" * 4300 + "3 1 0\n", "line 2: expected the vertex, face and edge counts"),
    ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 garbage\n", "line 6: after a face's indices"),
    ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 1 2\n", "line 6: after a face's indices"),
])
def test_malformed_files_name_the_problem(tmp_path, text, message):
    with pytest.raises(ValueError, match="could not read a mesh from") as err:
        zbuffer.load(write(tmp_path, text))
    assert message in str(err.value)


@pytest.mark.parametrize("header", [b"OFF BINARY\n", b"COFF BINARY # colours\n"])
def test_binary_off_is_refused_by_name(tmp_path, header):
    # A well-formed Geomview binary OFF triangle (big-endian counts, floats
    # and faces): neither zbuffer's reader nor trimesh's reads the format.
    body = np.array([3, 1, 0], ">i4").tobytes() + np.eye(3, dtype=">f4").tobytes() \
        + np.array([3, 0, 1, 2, 0], ">i4").tobytes()
    path = tmp_path / "binary.off"
    path.write_bytes(header + body)
    with pytest.raises(ValueError, match="is a binary OFF file, which zbuffer cannot read"):
        zbuffer.load(path)


@pytest.mark.skipif(not (MODELS / "bunny_7k.off").is_file(), reason="shared models not present")
def test_a_triangle_mesh_reads_as_trimesh_reads_it():
    import trimesh

    path = MODELS / "bunny_7k.off"
    mesh = zbuffer.load(path, merge_vertices=False)
    tm = trimesh.load(path, force="mesh", process=False)
    np.testing.assert_array_equal(mesh.vertices, tm.vertices)
    np.testing.assert_array_equal(mesh.faces, tm.faces)
    assert mesh.polygon_sizes is None


@pytest.mark.parametrize("header", ["OFF", "COFF", "NOFF"])
def test_counts_run_into_the_header_as_modelnet_writes_them(tmp_path, header):
    # The ModelNet datasets' OFF files begin "OFF9278 6940 0" (trimesh,
    # pytorch3d and MeshLib read them too): the same mesh as "OFF\n9278 ...".
    vertex = {"OFF": "", "COFF": " 255 0 0", "NOFF": " 0 0 1"}[header]
    body = "".join(f"{x} {y} 0{vertex}\n" for x, y in [(0, 0), (1, 0), (0, 1), (1, 1)])
    body += "3 0 1 2\n3 1 3 2\n"
    joined = zbuffer.load(write(tmp_path, f"{header}4 2 0\n" + body, "joined.off"),
                          merge_vertices=False)
    apart = zbuffer.load(write(tmp_path, f"{header}\n4 2 0\n" + body, "apart.off"),
                         merge_vertices=False)
    np.testing.assert_array_equal(joined.vertices, apart.vertices)
    np.testing.assert_array_equal(joined.faces, apart.faces)
    assert (joined.vertex_colors is None) == (header != "COFF")
    for text in ["OFFx4 2 0\n", "OFF+4 2 0\n", "XOFF4 2 0\n"]:  # not a header run into a count
        with pytest.raises(ValueError, match=r"bad.off.: not an OFF file \(the first record is"):
            zbuffer.load(write(tmp_path, text + body, "bad.off"))
