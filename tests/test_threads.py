"""Renders release the GIL and may run in parallel threads: same bits."""

from concurrent.futures import ThreadPoolExecutor

import numpy as np

import zbuffer
from zbuffer import scenes


def test_parallel_renders_equal_sequential_ones():
    meshes = [scenes.default_scene(), scenes.random_soup(3000, seed=7, scale=0.2),
              scenes.overlapping_boxes(20, seed=3), scenes.tessellated_square(30, 0.4, seed=1)]
    jobs = [(m, size, shading, algo) for m in meshes for size in [(64, 48), (97, 131)]
            for shading in ["none", "smooth"] for algo in zbuffer.algorithms()]

    def run(job):
        mesh, (w, h), shading, algo = job
        return zbuffer.render(mesh, algo=algo, width=w, height=h, shading=shading)

    sequential = [run(job) for job in jobs]
    with ThreadPoolExecutor(max_workers=4) as pool:
        parallel = list(pool.map(run, jobs * 3))
    for k, res in enumerate(parallel):
        ref = sequential[k % len(jobs)]
        np.testing.assert_array_equal(res.triangle_id, ref.triangle_id)
        np.testing.assert_array_equal(res.depth, ref.depth)
        if ref.image is not None:
            np.testing.assert_array_equal(res.image, ref.image)


def test_visit_passes_arrays_no_other_thread_can_write(monkeypatch):
    # The core checks a visit's arrays, then reads them without the GIL: a
    # writeable array (which another thread could change in between: out of
    # range indices, a crash) goes as a copy, a Mesh's read-only ones as they are.
    from zbuffer import _core

    passed = {}

    def fake_render(vertices, faces, *args, **kwargs):
        passed.update(vertices=vertices, faces=faces, ids=kwargs["face_ids"])
        return None

    monkeypatch.setattr(_core, "render", fake_render)
    vertices = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    faces = np.array([[0, 1, 2]], np.int32)
    ids = np.array([0], np.int32)
    zbuffer.Visit(vertices, faces, ids).render(np.eye(4), 8, 8, "zbuffer", False)
    for name, mine in (("vertices", vertices), ("faces", faces), ("ids", ids)):
        assert not np.shares_memory(passed[name], mine)
        np.testing.assert_array_equal(passed[name], mine)
    mesh = zbuffer.Mesh(vertices, faces)
    mesh.faces_for_render().render(np.eye(4), 8, 8, "zbuffer", False)
    assert passed["faces"] is mesh.faces and passed["vertices"] is mesh.vertices


def test_renders_into_own_arrays_share_a_prepared_mesh():
    # Threads rendering one prepared mesh into arrays of their own: each
    # render checks its arrays against the mesh's (Mesh.arrays) while others
    # fill the mesh's shading caches (Mesh.for_shading). A thread switch
    # every microsecond, fresh meshes: the checks meet the caches mid-fill.
    import sys
    import threading

    from helpers import run_in_threads

    base = scenes.instance_grid(scenes.default_scene(), (2, 2, 2))
    colours = np.random.default_rng(0).random((len(base.vertices), 3))
    w = h = 24
    errors = []
    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        for _ in range(20):
            mesh = zbuffer.Mesh(base.vertices, base.faces, vertex_colors=colours).prepare()
            cam = zbuffer.Camera.fit(mesh)
            ref = zbuffer.render(zbuffer.Mesh(base.vertices, base.faces, vertex_colors=colours),
                                 camera=cam, width=w, height=h, shading="smooth")
            barrier = threading.Barrier(4)

            def work():
                out = (np.empty((h, w), np.float32), np.empty((h, w), np.int32),
                       np.empty((h, w, 3), np.uint8))
                barrier.wait()
                for shading in ("flat", "smooth"):
                    res = zbuffer.render(mesh, camera=cam, width=w, height=h,
                                         shading=shading, out=out)
                np.testing.assert_array_equal(res.image, ref.image)

            errors += run_in_threads(work, 4)
    finally:
        sys.setswitchinterval(interval)
    assert not errors, errors[0]
