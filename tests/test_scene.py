"""zbuffer.Scene and the object-space trees of hiz_octree and hiz_bvh: built
once, rendered from many cameras, temporal coherence, node arrays, and the
same bits as the reference throughout."""

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from hypothesis import given, settings

import zbuffer
from zbuffer import _core, scenes
from zbuffer.polygons import triangulate_polygons
from zbuffer.scene import NODE_FATES, OCTREE_RULES, TREE_ALGORITHMS
from helpers import TREE_ALGORITHMS as REGISTERED_TREES
from helpers import assert_same_counters, assert_same_visibility, counters_add_up, reference_for
from test_properties import MVP, SIZE, render_reference, to_arrays, triangles

TREES = sorted(TREE_ALGORITHMS)
# (algorithm, Scene options): every tree and every octree rule, with small
# leaves so that the small test scenes get deep trees.
VARIANTS = [("hiz_octree", {"leaf_size": 4}), ("hiz_octree", {"leaf_size": 4, "octree_rule": "greene"}),
            ("hiz_octree", {"leaf_size": 4, "octree_rule": "smallest"}),
            ("hiz_octree", {"leaf_size": 32, "max_depth": 3}), ("hiz_bvh", {"leaf_size": 4}),
            ("hiz_bvh", {})]


def test_the_registry_and_the_scene_agree_on_tree_algorithms():
    assert sorted(REGISTERED_TREES) == TREES


def occluded_grid(n=6):
    """A 3 x 3 x n grid of spheres: the front layer hides most of the rest."""
    sphere = scenes.uv_sphere((0, 0, 0), 0.5, 8, 16)
    return scenes.instance_grid(scenes.combine([sphere]), (3, 3, n), spacing=1.05)


def camera_path(mesh, n=5):
    c, r = mesh.bounding_sphere
    for k in range(n):
        a = 0.15 * k
        yield zbuffer.Camera.look_at(c + r * np.array([np.sin(a), 0.1 * k, 1.6 * np.cos(a)]), c,
                                     fov_y=50, near=0.05 * r, far=5 * r)


@pytest.mark.parametrize("algo, options", VARIANTS)
def test_one_tree_many_cameras_equals_the_reference(algo, options):
    mesh = occluded_grid()
    scene = zbuffer.Scene(mesh, **options)
    culled_in_nodes = 0
    for k, cam in enumerate(camera_path(mesh)):
        res = scene.render(cam, algo=algo, width=80, height=64, shading="none")
        ref = zbuffer.reference.render(mesh, camera=cam, width=80, height=64, shading="none")
        assert_same_visibility(res, ref)
        assert_same_counters(res.stats, ref.stats)
        assert (res.stats["build_ms"] > 0) == (k == 0)  # built by the first render only
        # The depth buffer and the pyramid levels kept above it (8x8 cells up).
        assert res.stats["depth_storage_bytes"] > 4 * 80 * 64
        # Whole nodes were culled: in every frame with small leaves; over the
        # path with the default leaves of 1024 triangles (a view from the side
        # hides no whole leaf of this grid).
        if options.get("leaf_size"):
            assert res.stats["culled_in_nodes"] > 0
        culled_in_nodes += res.stats["culled_in_nodes"]
    assert culled_in_nodes > 0
    assert scene.tree_info(algo)["faces"] == len(mesh.faces)


@pytest.mark.parametrize("algo, options", VARIANTS)
def test_temporal_coherence_changes_no_bit(algo, options):
    mesh = occluded_grid()
    scene = zbuffer.Scene(mesh, **options)
    fresh = zbuffer.Scene(mesh, **options)
    temporal_culled = plain_culled = 0
    for cam in camera_path(mesh, 6):
        a = scene.render(cam, algo=algo, width=72, height=60, shading="none", temporal=True)
        b = fresh.render(cam, algo=algo, width=72, height=60, shading="none")
        assert_same_visibility(a, b)
        assert counters_add_up(a.stats) and counters_add_up(b.stats)
        temporal_culled += a.stats["nodes_hidden"]
        plain_culled += b.stats["nodes_hidden"]
    # Starting from last frame's visible set, the pyramid is complete sooner.
    assert temporal_culled >= plain_culled and temporal_culled > 0


@pytest.mark.parametrize("algo", TREES)
def test_zbuffer_render_builds_per_frame_and_reports_build_time(algo):
    mesh = occluded_grid(4)
    res = zbuffer.render(mesh, algo=algo, width=64, height=48, shading="none")
    ref = zbuffer.reference.render(mesh, width=64, height=48, shading="none")
    assert_same_visibility(res, ref)
    assert res.stats["build_ms"] > 0
    assert res.stats["nodes_visited"] > 0


def test_greene_rule_shares_faces_and_draws_each_once():
    # Triangles crossing the octree's split planes: Greene's rule puts them
    # in several cells; drawn once each, the counters still add up to the
    # input faces, and the output is the reference's.
    mesh = scenes.random_soup(400, seed=5, scale=0.3)
    scene = zbuffer.Scene(mesh, leaf_size=2, octree_rule="greene")
    cam = zbuffer.Camera.fit(mesh, direction=(0.1, 0.2, 1.0), aspect=1.0)
    res = scene.render(cam, width=64, height=64, shading="none")
    ref = zbuffer.reference.render(mesh, camera=cam, width=64, height=64, shading="none")
    assert scene.tree_info()["references"] > len(mesh.faces)
    assert_same_visibility(res, ref)
    assert_same_counters(res.stats, ref.stats)


@pytest.mark.parametrize("algo, options", VARIANTS)
def test_nodes_nest_and_hold_their_triangles(algo, options):
    mesh = occluded_grid(3)
    scene = zbuffer.Scene(mesh, **options)
    nodes = scene.nodes(algo)
    lo, hi, parent = nodes["lo"], nodes["hi"], nodes["parent"]
    assert parent[0] == -1 and (parent[1:] >= 0).all()
    np.testing.assert_array_equal(lo[0], mesh.vertices.min(axis=0))
    np.testing.assert_array_equal(hi[0], mesh.vertices.max(axis=0))
    child = np.arange(1, len(parent))
    assert (lo[child] >= lo[parent[child]]).all() and (hi[child] <= hi[parent[child]]).all()
    assert (nodes["depth"][child] == nodes["depth"][parent[child]] + 1).all()
    assert_node_counts(nodes, scene.tree_info(algo))
    assert (nodes["fate"] == 0).all()  # not rendered yet


def assert_node_counts(nodes, info):
    """n_triangles of a node: its own cluster's references plus its
    children's (a leaf: its own); the root's: every reference."""
    children = np.zeros_like(nodes["n_triangles"])
    np.add.at(children, nodes["parent"][1:], nodes["n_triangles"][1:])
    np.testing.assert_array_equal(nodes["n_triangles"], nodes["own_triangles"] + children)
    assert nodes["n_triangles"][0] == info["references"] == nodes["own_triangles"].sum()


def test_greene_leaves_count_each_face_once():
    # Under Greene's rule a face is referenced from every cell it overlaps;
    # a leaf holding several of them keeps it once. Node counts follow what
    # the clusters hold, and a leaf is decided by the faces it names: a tree
    # of fewer faces than leaf_size is one node.
    mesh = zbuffer.Mesh(*scenes.uv_sphere(n_lat=48, n_lon=96))
    scene = zbuffer.Scene(mesh, leaf_size=16, octree_rule="greene")
    nodes, info = scene.nodes("hiz_octree"), scene.tree_info("hiz_octree")
    assert info["references"] > len(mesh.faces)  # faces shared by cells
    assert_node_counts(nodes, info)
    whole = zbuffer.Scene(mesh, leaf_size=len(mesh.faces), max_depth=10, octree_rule="greene")
    assert whole.tree_info("hiz_octree")["nodes"] == 1


def test_node_fates_follow_the_last_render():
    mesh = occluded_grid()
    scene = zbuffer.Scene(mesh, leaf_size=4)
    c, r = mesh.bounding_sphere
    # Looking at the front layer from close by: part of the grid is off
    # screen, most of the rest hidden.
    cam = zbuffer.Camera.look_at(c + np.array([0.3, 0.2, 1.0]) * r, c, fov_y=40)
    res = scene.render(cam, width=64, height=64, shading="none")
    fate = scene.nodes()["fate"]
    counts = np.bincount(fate, minlength=len(NODE_FATES))
    assert fate[0] in (3, 4)  # the root is visited
    assert counts[NODE_FATES.index("outside")] == res.stats["nodes_outside"]
    assert counts[NODE_FATES.index("hidden")] == res.stats["nodes_hidden"]
    assert counts[3] + counts[4] == res.stats["nodes_visited"]
    assert counts[NODE_FATES.index("hidden")] > 0 and counts[NODE_FATES.index("drawn")] > 0


def test_non_tree_algorithms_render_through_a_scene():
    mesh = scenes.default_scene()
    scene = zbuffer.Scene(mesh)
    for algo in zbuffer.algorithms():
        res = scene.render(algo=algo, width=48, height=40, shading="flat")
        ref = zbuffer.render(mesh, algo=algo, width=48, height=40, shading="flat")
        assert_same_visibility(res, ref)
        np.testing.assert_array_equal(res.image, ref.image)


def test_empty_scene():
    mesh = zbuffer.Mesh(np.zeros((0, 3)), np.zeros((0, 3), np.int32))
    scene = zbuffer.Scene(mesh)
    cam = zbuffer.Camera.look_at((0, 0, 3), (0, 0, 0), near=1, far=10)
    for algo in TREES:
        res = scene.render(cam, algo=algo, width=16, height=8, shading="none", temporal=True)
        assert not res.mask.any() and res.stats["nodes_visited"] == 0
        assert scene.nodes(algo)["lo"].shape == (0, 3)


def test_parallel_renders_of_one_scene():
    mesh = occluded_grid()
    scene = zbuffer.Scene(mesh, leaf_size=8)
    cams = list(camera_path(mesh, 4))
    expected = [zbuffer.render(mesh, camera=c, width=60, height=50, shading="none") for c in cams]

    def run(k):
        return scene.render(cams[k % 4], algo=TREES[k % 2], width=60, height=50, shading="none",
                            temporal=k % 3 == 0)

    with ThreadPoolExecutor(max_workers=4) as pool:
        results = list(pool.map(run, range(24)))
    for k, res in enumerate(results):
        assert_same_visibility(res, expected[k % 4])


@settings(max_examples=100, deadline=None)
@given(triangles)
def test_tiny_leaves_on_the_fixed_point_grid(tris):
    # Heavy overlap, exact ties and degenerate triangles, with a node for
    # every triangle or two: no node test may cull anything that wins a pixel.
    v, f = to_arrays(tris)
    depth, ids, ref_stats = render_reference(v, f)
    for tree in (*(_core.build_octree(v, f, 1, 10, rule) for rule in OCTREE_RULES),
                 _core.build_bvh(v, f, 1)):
        d, i, stats = tree.render(MVP, SIZE, SIZE)
        np.testing.assert_array_equal(i, ids)
        np.testing.assert_array_equal(d, depth)
        assert counters_add_up(stats)
        assert stats["triangles_in"] == len(f)


def test_bad_arguments():
    mesh = scenes.default_scene()
    for leaf in (0, 2**31):  # (the core takes an int32)
        with pytest.raises(ValueError, match=r"leaf_size must be in 1 \.\. 2147483647"):
            zbuffer.Scene(mesh, leaf_size=leaf)
    with pytest.raises(TypeError, match="leaf_size must be an int"):
        zbuffer.Scene(mesh, leaf_size=2.5)
    for depth in (0, 11):
        with pytest.raises(ValueError, match="max_depth must be in 1 .. 10"):
            zbuffer.Scene(mesh, max_depth=depth)
    with pytest.raises(TypeError, match="max_depth must be an int"):
        zbuffer.Scene(mesh, max_depth=True)
    with pytest.raises(ValueError, match="unknown octree_rule 'octant'"):
        zbuffer.Scene(mesh, octree_rule="octant")
    with pytest.raises(TypeError, match="octree_rule must be one of 'loose', 'smallest', 'greene', got None"):
        zbuffer.Scene(mesh, octree_rule=None)
    scene = zbuffer.Scene(mesh)
    # A Scene's mesh and a Mesh's arrays are fixed (a tree over other faces
    # than those shaded read out of bounds: a fuzzer's find).
    with pytest.raises(AttributeError):
        scene.mesh = zbuffer.Mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(AttributeError):
        mesh.faces = mesh.faces[:1]
    with pytest.raises(AttributeError):
        mesh.vertices = mesh.vertices * 2
    with pytest.raises(ValueError, match="unknown algorithm 'octree'"):
        scene.render(algo="octree")
    with pytest.raises(ValueError, match="temporal coherence needs a tree algorithm"):
        scene.render(algo="hiz", temporal=True)
    with pytest.raises(TypeError, match="temporal must be a bool"):
        scene.render(temporal="yes")
    with pytest.raises(TypeError, match="cull_backfaces must be a bool"):
        scene.render(cull_backfaces="no")
    with pytest.raises(ValueError, match="'zbuffer' has no tree"):
        scene.nodes("zbuffer")
    with pytest.raises(ValueError, match="width and height must be positive"):
        scene.render(width=0)
    with pytest.raises(ValueError, match='unknown octree rule "octant"; valid rules are "loose", "smallest", "greene"'):
        _core.build_octree(mesh.vertices, mesh.faces, 8, 10, "octant")
    with pytest.raises(ValueError, match="face 0 has vertex index"):
        _core.build_bvh(mesh.vertices, np.array([[0, 1, 10**6]], np.int32))


@pytest.mark.parametrize("algo", sorted(set(zbuffer.algorithms()) - set(TREE_ALGORITHMS)))
def test_scene_renders_a_prepared_mesh_through_its_own_vertices(algo):
    # A prepared mesh is visited through its renumbered vertices
    # (Mesh.faces_for_render); Scene.render must pass those, not the mesh's.
    mesh = occluded_grid(4).prepare()
    assert len(mesh.faces) >= mesh._ORDER_MIN_FACES
    visit = mesh.faces_for_render()
    assert visit.vertices is not mesh.vertices and not np.array_equal(visit.vertices, mesh.vertices)
    cam = next(camera_path(mesh, 1))
    ours = zbuffer.Scene(mesh).render(cam, algo=algo, width=96, height=72, shading="none")
    ref = zbuffer.reference.render(mesh, camera=cam, width=96, height=72, shading="none")
    assert_same_visibility(ours, ref)


@pytest.mark.parametrize("algo", sorted(set(zbuffer.algorithms()) - set(TREE_ALGORITHMS)))
def test_scene_draws_polygon_faces_as_render_does(algo):
    # A concave hexagon in front of a tilted quad: `scanline` draws the
    # polygons as written through Scene.render too, the others their
    # triangulation -- the same call as zbuffer.render either way.
    hexagon = [(0, 0), (4, 0), (4, 2), (2, 2), (2, 4), (0, 4)]
    v = np.array([[x / 4.0 - 0.5, y / 4.0 - 0.5, 0.0] for x, y in hexagon]
                 + [[-0.6, -0.6, -0.5], [0.6, -0.6, -0.3], [0.6, 0.6, -0.1], [-0.6, 0.6, -0.3]])
    sizes, idx = np.array([6, 4]), np.arange(10)
    faces, _ = triangulate_polygons(v, sizes, idx)
    mesh = zbuffer.Mesh(v, faces, polygons=(sizes, idx))
    cam = zbuffer.Camera.look_at((0.2, 0.1, 2), (0, 0, 0), projection="orthographic",
                                 ortho_height=1.5)
    kwargs = dict(camera=cam, width=48, height=40, shading="none")
    ours = zbuffer.Scene(mesh).render(algo=algo, **kwargs)
    assert_same_visibility(ours, reference_for(algo, mesh, **kwargs))
    once = zbuffer.render(mesh, algo=algo, **kwargs)
    for key in ("rasterized", "polygons_inserted", "pixels_tested"):
        assert ours.stats.get(key) == once.stats.get(key), key


@pytest.mark.parametrize("algo", TREE_ALGORITHMS)
def test_scene_render_culls_backfaces(algo):
    # (Scene.render passing cull_backfaces on to the trees was untested: the
    # suite passed with it dropped -- a test-gap review.)
    mesh = scenes.random_soup(300, seed=2)
    cam = zbuffer.Camera.fit(mesh, direction=(0.3, 0.4, 1.0), aspect=4 / 3)
    scene = zbuffer.Scene(mesh)
    kw = dict(camera=cam, width=96, height=72, shading="none")
    ids = {}
    for cull in (False, True):
        got = scene.render(algo=algo, cull_backfaces=cull, **kw)
        assert_same_visibility(got, zbuffer.reference.render(mesh, cull_backfaces=cull, **kw))
        assert (got.stats["culled_backface"] > 0) == cull
        ids[cull] = got.triangle_id
    assert not np.array_equal(ids[False], ids[True])


def test_combine_colours_parts_as_render_takes_colours():
    tri = (np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float), np.array([[0, 1, 2]]))
    two = (np.vstack([tri[0], tri[0] + 2]), np.array([[0, 1, 2], [3, 4, 5]]))
    mesh = scenes.combine([tri, two], colors=[(255, 0, 0), (0.0, 0.5, 1.0)])
    np.testing.assert_array_equal(mesh.face_colors,
                                  np.array([[1, 0, 0], [0, 0.5, 1], [0, 0.5, 1]], np.float32))
    assert scenes.combine([tri, two], colors=None).face_colors is None
    with pytest.raises(ValueError, match="colors: one per part, got 1 for 2 parts"):
        scenes.combine([tri, two], colors=[(255, 0, 0)])
    with pytest.raises(ValueError, match=r"integer colors\[1\] must lie in 0-255"):
        scenes.combine([tri, two], colors=[(255, 0, 0), (0, 256, 0)])
    with pytest.raises(ValueError, match=r"colors\[0\] must be 3 numbers"):
        scenes.combine([tri, two], colors=[(1.0, 0.0), (0.0, 0.0, 0.0)])
