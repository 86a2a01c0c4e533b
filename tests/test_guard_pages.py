"""Every access the core makes stays inside the caller's arrays.

The depth and id planes are passed with ``out=`` as arrays that end (or
start) right at a page the process may not touch, and small triangles are
drawn all along the image's edges -- where the vector loops' masked-off
lanes and rows would reach past a plane. AddressSanitizer cannot check
masked vector accesses; an unmapped page can: a stray access kills the
process. Each batch of renders runs in a child process, so that such a
crash fails a test instead of the whole run.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

import zbuffer

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"),
                                reason="guard pages by mmap and mprotect (Linux)")

CHILD = r"""
import ctypes, mmap, sys
import numpy as np
import zbuffer

libc = ctypes.CDLL(None, use_errno=True)
libc.mprotect.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int]
PAGE = mmap.PAGESIZE
keep = []


def guarded(shape, dtype, at_end):
    # A C-contiguous array whose last (at_end) or first byte touches a
    # PROT_NONE page.
    n = int(np.prod(shape)) * np.dtype(dtype).itemsize
    pages = (n + PAGE - 1) // PAGE + 2
    mm = mmap.mmap(-1, pages * PAGE)
    base = ctypes.addressof(ctypes.c_char.from_buffer(mm))
    for page in (0, pages - 1):
        if libc.mprotect(base + page * PAGE, PAGE, 0) != 0:
            raise OSError(ctypes.get_errno(), "mprotect")
    start = (pages - 1) * PAGE - n if at_end else PAGE
    keep.append(mm)
    return np.frombuffer(mm, np.uint8, count=n, offset=start).view(dtype).reshape(shape)


algo, seed = sys.argv[1], int(sys.argv[2])
rng = np.random.default_rng(seed)
for case in range(40):
    w, h = int(rng.integers(1, 41)), int(rng.integers(1, 21))
    at_end = bool(case % 2 == 0)
    depth = guarded((h, w), np.float32, at_end)
    ids = guarded((h, w), np.int32, at_end)
    n = int(rng.integers(1, 60))
    # Triangle centres near the image's edges (mostly the right and bottom
    # ones), sizes from a fraction of a pixel to 20 pixels, some crossing out.
    cx = np.where(rng.random(n) < 0.6, w - rng.uniform(-2, 9, n), rng.uniform(-2, w + 2, n))
    cy = np.where(rng.random(n) < 0.6, h - rng.uniform(-2, 9, n), rng.uniform(-2, h + 2, n))
    size = rng.choice([0.4, 1.5, 4.0, 9.0, 20.0], n)[:, None]
    x = cx[:, None] + rng.normal(size=(n, 3)) * size
    y = cy[:, None] + rng.normal(size=(n, 3)) * size
    z = rng.uniform(-1, 1, (n, 3))
    # pixel coordinates to world coordinates of an orthographic camera
    verts = np.stack([x - w / 2, h / 2 - y, z], -1).reshape(-1, 3)
    faces = np.arange(3 * n, dtype=np.int32).reshape(-1, 3)
    cam = zbuffer.Camera.look_at((0, 0, 10), (0, 0, 0), projection="orthographic",
                                 ortho_height=float(h), near=1, far=30)
    kw = dict(algo=algo, camera=cam, width=w, height=h, shading="none")
    got = zbuffer.render((verts, faces), out=(depth, ids), **kw)
    want = zbuffer.render((verts, faces), **kw)
    assert np.array_equal(got.depth, want.depth) and np.array_equal(got.triangle_id, want.triangle_id), case
print("ok")
"""


@pytest.mark.parametrize("algo", zbuffer.algorithms())
@pytest.mark.parametrize("seed", [1, 2])
def test_no_access_outside_the_planes(algo, seed):
    done = subprocess.run([sys.executable, "-c", CHILD, algo, str(seed)], capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0 and done.stdout.strip() == "ok", (
        f"exit {done.returncode} (a negative code is a signal: {-done.returncode} = SIGSEGV "
        f"when 11)\n{done.stdout}\n{done.stderr}")
