"""Renders release the GIL and may run in parallel threads: same bits."""

from concurrent.futures import ThreadPoolExecutor

import numpy as np

import zbuffer
from zbuffer import scenes


def test_parallel_renders_equal_sequential_ones():
    meshes = [scenes.default_scene(), scenes.random_soup(3000, seed=7, scale=0.2),
              scenes.overlapping_boxes(20, seed=3), scenes.tessellated_square(30, 0.4, seed=1)]
    jobs = [(m, size, shading) for m in meshes for size in [(64, 48), (97, 131)]
            for shading in ["none", "smooth"]]

    def run(job):
        mesh, (w, h), shading = job
        return zbuffer.render(mesh, width=w, height=h, shading=shading)

    sequential = [run(job) for job in jobs]
    with ThreadPoolExecutor(max_workers=4) as pool:
        parallel = list(pool.map(run, jobs * 3))
    for k, res in enumerate(parallel):
        ref = sequential[k % len(jobs)]
        np.testing.assert_array_equal(res.triangle_id, ref.triangle_id)
        np.testing.assert_array_equal(res.depth, ref.depth)
        if ref.image is not None:
            np.testing.assert_array_equal(res.image, ref.image)
