"""Real models from ../shared/models, every algorithm against the reference.

Skipped cleanly when the models folder is absent.
"""

import numpy as np
import pytest

import zbuffer
from helpers import (ALGORITHMS, POLYGON_ALGORITHMS, assert_same_counters,
                     assert_same_visibility, model_path, reference_for)

pytestmark = pytest.mark.models

# Every loader path: OBJ (ours, with quads, groups, relative indices, CRLF),
# PLY, OFF, STL, textures whose image is missing.
MODELS = [
    "bunny_10k.obj", "spot.obj", "teapot_6k.obj", "cow_6k.obj", "knob_4k.obj",
    "african_head.obj", "dragon_20k.obj", "happy_buddha_20k.obj", "cornell_box_original.obj",
    "six_boxes.obj", "desk.obj", "woody_flat.obj", "suzanne.obj", "flowers.obj",
    "bunny_16k.ply", "fuze.ply", "bunny_7k.off", "comments.off", "teapot.stl", "multibody.stl",
]


@pytest.mark.parametrize("algo", ALGORITHMS)
@pytest.mark.parametrize("name", MODELS)
def test_model_equals_reference(algo, name):
    mesh = zbuffer.load(model_path(name))
    assert len(mesh.faces) > 0
    w, h = 96, 72
    cams = [
        (zbuffer.Camera.fit(mesh, direction=(0.3, 0.2, 1.0), aspect=w / h), False),
        (zbuffer.Camera.fit(mesh, direction=(-1.0, 0.5, -0.4), aspect=w / h,
                            projection="orthographic"), True),
    ]
    drawn = 0
    for cam, cull in cams:
        res = zbuffer.render(mesh, algo=algo, camera=cam, width=w, height=h, shading="none",
                             cull_backfaces=cull)
        ref = reference_for(algo, mesh, camera=cam, width=w, height=h, shading="none",
                            cull_backfaces=cull)
        assert_same_visibility(res, ref)
        drawn += int(res.mask.sum())
        assert_same_counters(res.stats, ref.stats)
    assert drawn > 100  # (a flat mesh seen from behind with culling shows nothing)


@pytest.mark.parametrize("name", ["bunny_69k.obj", "armadillo_86k.obj"])
def test_large_model_equals_reference_close_up(name):
    # Close enough that triangles cross the near plane and the guard band.
    mesh = zbuffer.load(model_path(name))
    c, r = mesh.bounding_sphere
    eye = c + np.array([0.1, 0.05, 0.9]) * r
    # Near plane through the mesh: a tenth of its vertices lie in front of it.
    depth_along_view = (mesh.vertices - eye) @ ((c - eye) / np.linalg.norm(c - eye))
    near = float(np.quantile(depth_along_view[depth_along_view > 0], 0.1))
    cam = zbuffer.Camera.look_at(eye, c, fov_y=60, near=near, far=4 * r)
    kw = dict(camera=cam, width=128, height=96, shading="none")
    refs = {}  # (by the polygons flag: one reference for a mesh of triangles)
    for algo in ALGORITHMS:
        res = zbuffer.render(mesh, algo=algo, **kw)
        polygons = algo in POLYGON_ALGORITHMS
        if polygons not in refs:
            refs[polygons] = reference_for(algo, mesh, **kw)
        assert_same_visibility(res, refs[polygons])
        assert res.stats["clipped"] > 0


def test_african_head_with_its_eyes_as_one_scene():
    import trimesh

    head = trimesh.load(model_path("african_head.obj"), force="mesh", process=False)
    eyes = trimesh.load(model_path("african_head_eye_inner.obj"), force="mesh", process=False)
    scene = trimesh.Scene([head, eyes])
    ref = zbuffer.reference.render(scene, width=80, height=80, shading="none")
    for algo in ALGORITHMS:  # (triangles only: one reference for all)
        res = zbuffer.render(scene, algo=algo, width=80, height=80, shading="none")
        assert_same_visibility(res, ref)
        assert res.stats["triangles_in"] == len(head.faces) + len(eyes.faces)
