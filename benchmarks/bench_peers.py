"""zbuffer against the tools people use instead, in one run: Open3D's
RaycastingScene (a BVH ray caster), VTK's offscreen OpenGL rendering
(through pyvista) and pyrender's (through OSMesa) on the same meshes, camera
and pixels.

    python benchmarks/bench_peers.py                 # -> benchmarks/results/peers.{json,md}
    python benchmarks/bench_peers.py --grid 10 80    # values of N for the spot grid
    python benchmarks/bench_peers.py --quick         # smoke mode (skips what is not installed)

Open3D and pyrender are optional: ``pip install open3d`` (on Debian it needs
libusb-1.0-0); ``pip install pyrender`` and then ``pip install --no-deps
"pyopengl>=3.1.7"`` (pyrender pins PyOpenGL 3.1.0, whose OSMesa binding
lacks what pyrender calls; Debian: ``apt-get install libosmesa6``). VTK comes
with pyvista and renders offscreen through EGL (Mesa's software OpenGL on
these machines). Open3D casts one ray per pixel centre of our camera (the
pixel centres zbuffer samples); VTK and pyrender get our camera (position,
target, up, field of view or parallel scale, near and far). Each peer's depth
map is compared with ours: pixels where one sees the mesh and the other does
not, and the relative difference of the distance (along the ray for Open3D,
along the view axis for VTK) where both do. Times: median of --runs frames;
Open3D's build is the scene construction plus a cast of one ray (it builds
its BVH lazily, at the first cast), on its default thread count (2 here)
and, for the frames, on one thread too; every frame, ours and theirs, is
timed from Python around the call. Builds, ours and Open3D's: median of --builds (3), each
into a new scene. Nothing here asserts a speed.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np

import zbuffer
from bench_hiz import grid_camera, spot
from common import MODELS, Progress, add_out_argument, new_report, out_folder, write_report


def pixel_rays(result: zbuffer.RenderResult):
    """(H, W, 6) float32 rays through every pixel centre of a render's camera:
    origins on the near plane, unit directions."""
    h, w = result.depth.shape
    inv = np.linalg.inv(result.mvp)
    x = (np.arange(w) + 0.5) / w * 2 - 1
    y = 1 - (np.arange(h) + 0.5) / h * 2
    xx, yy = np.meshgrid(x, y)
    def unproject(z):
        clip = np.stack([xx, yy, np.full_like(xx, z), np.ones_like(xx)], -1) @ inv.T
        return clip[..., :3] / clip[..., 3:]
    near, far = unproject(-1.0), unproject(1.0)
    d = far - near
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return np.concatenate([near, d], -1).astype(np.float32), near


def our_distance(result: zbuffer.RenderResult, origins: np.ndarray) -> np.ndarray:
    """Distance from each ray origin to the surface point zbuffer found (inf
    where nothing was drawn)."""
    h, w = result.depth.shape
    inv = np.linalg.inv(result.mvp)
    x = (np.arange(w) + 0.5) / w * 2 - 1
    y = 1 - (np.arange(h) + 0.5) / h * 2
    xx, yy = np.meshgrid(x, y)
    z = np.where(np.isfinite(result.depth), result.depth.astype(np.float64) * 2 - 1, 0.0)
    clip = np.stack([xx, yy, z, np.ones_like(xx)], -1) @ inv.T
    points = clip[..., :3] / clip[..., 3:]
    dist = np.linalg.norm(points - origins, axis=-1)
    return np.where(np.isfinite(result.depth), dist, np.inf)


def agreement(ours: np.ndarray, theirs: np.ndarray) -> dict:
    a, b = np.isfinite(ours), np.isfinite(theirs)
    both = a & b
    rel = np.abs(ours[both] - theirs[both]) / np.maximum(theirs[both], 1e-12)
    return {"pixels": int(a.size), "coverage_mismatch": int((a != b).sum()),
            "depth_rel_median": float(np.median(rel)) if both.any() else None,
            "depth_rel_p99": float(np.percentile(rel, 99)) if both.any() else None}


def bench_open3d(mesh, result, runs, builds):
    import open3d as o3d

    rays_np, origins = pixel_rays(result)
    rays = o3d.core.Tensor(rays_np)
    one_ray = o3d.core.Tensor(rays_np[:1])
    build_times = []
    for _ in range(builds):  # a new scene each time; the last one casts the frames
        scene = None
        t0 = time.perf_counter()
        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(o3d.core.Tensor(mesh.vertices.astype(np.float32)),
                            o3d.core.Tensor(mesh.faces.astype(np.uint32)))
        scene.cast_rays(one_ray)  # the BVH is built here (lazily: one ray casts next to nothing)
        build_times.append((time.perf_counter() - t0) * 1e3)
    out = {"build_ms": statistics.median(build_times), "build_ms_each": build_times}
    for label, threads in (("auto", 0), ("1", 1)):
        times = []
        for _ in range(runs):
            t0 = time.perf_counter()
            hit = scene.cast_rays(rays, nthreads=threads)
            times.append((time.perf_counter() - t0) * 1e3)
        out[f"frame_ms_threads_{label}"] = statistics.median(times)
    theirs = hit["t_hit"].numpy().astype(np.float64)
    out["agreement"] = agreement(our_distance(result, origins), theirs)
    return out


def bench_vtk(mesh, camera, result, runs):
    """VTK offscreen: build = the first frame (upload and first draw), frames
    = render() + get_image_depth(), on VTK's defaults."""
    import pyvista as pv

    pv.OFF_SCREEN = True
    size = result.depth.shape[1], result.depth.shape[0]
    t0 = time.perf_counter()
    faces = np.hstack([np.full((len(mesh.faces), 1), 3), mesh.faces]).ravel()
    plotter = pv.Plotter(off_screen=True, window_size=size)
    plotter.add_mesh(pv.PolyData(mesh.vertices, faces))
    cam = plotter.camera
    cam.position, cam.focal_point, cam.up = tuple(camera.eye), tuple(camera.target), tuple(camera.up)
    if camera.projection == "orthographic":
        plotter.enable_parallel_projection()
        cam.parallel_scale = camera.ortho_height / 2
    else:
        cam.view_angle = camera.fov_y
    cam.clipping_range = (camera.near, camera.far)
    plotter.show(auto_close=False)
    depth = plotter.get_image_depth(reset_camera_clipping_range=False)
    build_ms = (time.perf_counter() - t0) * 1e3
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        plotter.render()
        depth = plotter.get_image_depth(reset_camera_clipping_range=False)
        times.append((time.perf_counter() - t0) * 1e3)
    plotter.close()
    theirs = np.where(np.isfinite(depth), np.abs(depth), np.inf).astype(np.float64)
    return {"build_ms": build_ms, "frame_ms": statistics.median(times),
            "agreement": agreement(result.eye_depth().astype(np.float64), theirs)}


def bench_pyrender(mesh, camera, result, runs):
    """pyrender offscreen through OSMesa (Mesa's software OpenGL, no display):
    build = scene, renderer and the first frame; frames = a depth-only render."""
    os.environ.setdefault("PYOPENGL_PLATFORM", "osmesa")  # before OpenGL is imported
    import pyrender
    import trimesh

    h, w = result.depth.shape
    t0 = time.perf_counter()
    scene = pyrender.Scene()
    scene.add(pyrender.Mesh.from_trimesh(trimesh.Trimesh(mesh.vertices, mesh.faces, process=False),
                                         smooth=False))
    if camera.projection == "perspective":
        cam = pyrender.PerspectiveCamera(yfov=np.radians(camera.fov_y), aspectRatio=w / h,
                                         znear=camera.near, zfar=camera.far)
    else:
        ymag = camera.ortho_height / 2
        cam = pyrender.OrthographicCamera(xmag=ymag * w / h, ymag=ymag, znear=camera.near,
                                          zfar=camera.far)
    scene.add(cam, pose=np.linalg.inv(camera.view_matrix()))
    renderer = pyrender.OffscreenRenderer(w, h)
    try:
        depth = renderer.render(scene, flags=pyrender.RenderFlags.DEPTH_ONLY)
        build_ms = (time.perf_counter() - t0) * 1e3
        times = []
        for _ in range(runs):
            t0 = time.perf_counter()
            depth = renderer.render(scene, flags=pyrender.RenderFlags.DEPTH_ONLY)
            times.append((time.perf_counter() - t0) * 1e3)
    finally:
        renderer.delete()
    theirs = np.where(depth > 0, depth, np.inf).astype(np.float64)
    if camera.projection == "orthographic":
        # pyrender (0.1.45) linearizes every depth buffer as a perspective
        # one; undo that to get the buffer's NDC z, then the orthographic depth.
        n, f = camera.near, camera.far
        with np.errstate(divide="ignore"):
            ndc = (f + n - 2.0 * n * f / theirs) / (f - n)
        theirs = np.where(np.isfinite(theirs), (ndc * (f - n) + (f + n)) / 2.0, np.inf)
    return {"build_ms": build_ms, "frame_ms": statistics.median(times), "version": pyrender.__version__,
            "agreement": agreement(result.eye_depth().astype(np.float64), theirs)}


def wall_ms(call) -> float:
    """Milliseconds of one call, timed from Python (as the peers' calls are)."""
    t0 = time.perf_counter()
    call()
    return (time.perf_counter() - t0) * 1e3


def bench_ours(mesh, camera, size, runs, builds):
    out = {}
    render = lambda algo: zbuffer.render(mesh, algo=algo, camera=camera, width=size, height=size,
                                         shading="none")
    render("zbuffer")
    times = [wall_ms(lambda: render("zbuffer")) for _ in range(runs)]
    out["zbuffer_ms"] = statistics.median(times)
    build_times = []
    for _ in range(builds):  # a new Scene each time; the last one renders
        scene = None  # the previous tree is freed first, as a user's would be
        scene = zbuffer.Scene(mesh)
        t0 = time.perf_counter()
        scene.build("hiz_octree")
        build_times.append((time.perf_counter() - t0) * 1e3)
    out["hiz_octree_build_ms"] = statistics.median(build_times)
    out["hiz_octree_build_ms_each"] = build_times
    frame = lambda: scene.render(camera, algo="hiz_octree", width=size, height=size,  # noqa: E731
                                 shading="none")
    frame()
    out["hiz_octree_built_once_ms"] = statistics.median(wall_ms(frame) for _ in range(runs))
    return out, render("zbuffer")


def markdown(report) -> str:
    m = report["machine"]
    lines = [
        "# zbuffer against Open3D ray casting, VTK and pyrender: same meshes, camera and pixels",
        "",
        f"- date: {report['date']}",
        f"- machine: {m['cpu']}, {m['cores']} cores; Python {m['python']}, numpy {m['numpy']}",
        f"- commit: {m['commit']}; Open3D {report.get('open3d', 'not installed')}; pyrender "
        f"{next((c['pyrender']['version'] for c in report['cases'] if c.get('pyrender')), 'not run')}",
        f"- command: `{report['command']}`",
        f"- {report['size']}x{report['size']} pixels, one ray per pixel centre; median of "
        f"{report['runs']} frames, builds median of {report.get('builds', 1)} (each a new scene). "
        "Open3D build = scene + a one-ray cast (its BVH is built lazily, at the first cast); "
        "its frames on its default threads (auto = 2 here) and on one thread; ours on one.",
        "",
        "| scene | triangles | projection | Open3D build ms | Open3D frame ms (auto / 1 thread) "
        "| zbuffer ms | hiz_octree build ms | hiz_octree built once ms "
        "| Open3D 1 thread / hiz_octree | Open3D build / ours | coverage mismatch | "
        "rel. distance diff (median / p99) |",
        "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for c in report["cases"]:
        o = c.get("open3d")
        if o is None:
            continue
        a = o["agreement"]
        lines.append(
            f"| {c['scene']} | {c['triangles']:,} | {c['projection']} | {o['build_ms']:.0f} | "
            f"{o['frame_ms_threads_auto']:.1f} / {o['frame_ms_threads_1']:.1f} | "
            f"{c['zbuffer_ms']:.1f} | {c['hiz_octree_build_ms']:.0f} | "
            f"{c['hiz_octree_built_once_ms']:.1f} | "
            f"{o['frame_ms_threads_1'] / c['hiz_octree_built_once_ms']:.1f}x | "
            f"{o['build_ms'] / c['hiz_octree_build_ms']:.1f}x | "
            f"{a['coverage_mismatch']:,} of {a['pixels']:,} | "
            f"{a['depth_rel_median']:.1e} / {a['depth_rel_p99']:.1e} |")
    for key, title in (("vtk", "VTK offscreen (pyvista `render()` + `get_image_depth()`, Mesa's "
                                "software OpenGL through EGL here)"),
                       ("pyrender", "pyrender offscreen (`OffscreenRenderer.render`, depth only, "
                                    "Mesa's software OpenGL through OSMesa here)")):
        lines += peer_table(report, key, title)
    return "\n".join(lines) + "\n"


def peer_table(report, key: str, title: str) -> list:
    """Markdown lines comparing one OpenGL peer (`key` in the cases) with us."""
    cases = [c for c in report["cases"] if c.get(key)]
    if not cases:
        return []
    name = key if key == "pyrender" else key.upper()
    lines = ["", f"{title}, same cameras:", "",
             f"| scene | projection | {name} first frame ms | {name} frame ms | zbuffer ms "
             f"| hiz_octree built once ms | {name} / hiz_octree | coverage mismatch "
             "| rel. depth diff (median / p99) |",
             "|---|---|---:|---:|---:|---:|---:|---:|---|"]
    for c in cases:
        v, a = c[key], c[key]["agreement"]
        lines.append(
            f"| {c['scene']} | {c['projection']} | {v['build_ms']:.0f} | {v['frame_ms']:.1f} | "
            f"{c['zbuffer_ms']:.1f} | {c['hiz_octree_built_once_ms']:.1f} | "
            f"{v['frame_ms'] / c['hiz_octree_built_once_ms']:.0f}x | "
            f"{a['coverage_mismatch']:,} of {a['pixels']:,} | "
            f"{a['depth_rel_median']:.1e} / {a['depth_rel_p99']:.1e} |")
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke mode: tiny grid, 2 runs")
    parser.add_argument("--grid", type=int, nargs="*", default=None, help="values of N (default 10 80)")
    parser.add_argument("--runs", type=int, default=None, help="frames per case (default 5)")
    parser.add_argument("--builds", type=int, default=None,
                        help="builds per case, ours and Open3D's (default 3)")
    add_out_argument(parser)
    args = parser.parse_args(argv)
    runs = args.runs or (2 if args.quick else 5)
    builds = args.builds or (1 if args.quick else 3)
    if runs < 1 or builds < 1:
        parser.error("--runs and --builds must be at least 1")
    size = 128 if args.quick else 1024
    try:
        import open3d

        version = open3d.__version__
    except Exception as err:  # not installed, or a system library missing
        print(f"Open3D unavailable ({err}): nothing to compare with", flush=True)
        version = None
    report = {**new_report("bench_peers.py", argv), "size": size, "runs": runs, "builds": builds,
              "cases": []}
    if version:
        report["open3d"] = version
    base, label = spot(args.quick)
    scenes = [(f"5x5x{n} {label}", zbuffer.scenes.instance_grid(base, (5, 5, n)))
              for n in (args.grid or ([1] if args.quick else [10, 80]))]
    for name in ([] if args.quick else ["bunny_69k.obj", "armadillo_86k.obj"]):
        if (MODELS / name).is_file():
            scenes.append((name, zbuffer.load(MODELS / name)))
    progress = Progress("peers", 2 * len(scenes))
    for name, mesh in scenes:
        for projection in ("perspective", "orthographic"):
            if "x" in name.split()[0]:
                camera = grid_camera(mesh, projection)
            else:
                camera = zbuffer.Camera.fit(mesh, aspect=1.0, projection=projection).resolve(mesh)
            ours, result = bench_ours(mesh, camera, size, runs, builds)
            case = {"scene": name, "triangles": len(mesh.faces), "projection": projection, **ours}
            said = [f"zbuffer {ours['zbuffer_ms']:.1f} ms, hiz_octree build "
                    f"{ours['hiz_octree_build_ms']:.0f} ms + {ours['hiz_octree_built_once_ms']:.1f} ms"]
            if version:
                case["open3d"] = o = bench_open3d(mesh, result, runs, builds)
                said.append(f"Open3D build {o['build_ms']:.0f} ms + {o['frame_ms_threads_auto']:.1f} ms "
                            f"({o['frame_ms_threads_1']:.1f} ms on one thread), "
                            f"{o['agreement']['coverage_mismatch']} pixels differ")
            for key, peer in (("vtk", bench_vtk), ("pyrender", bench_pyrender)):
                try:
                    case[key] = p = peer(mesh, camera, result, runs)
                    said.append(f"{key} {p['build_ms']:.0f} ms + {p['frame_ms']:.1f} ms, "
                                f"{p['agreement']['coverage_mismatch']} pixels differ")
                except Exception as err:  # not installed, or no OpenGL context here
                    said.append(f"{key} skipped ({type(err).__name__}: {err})")
            progress(f"{name} {projection}: " + "; ".join(said))
            report["cases"].append(case)
    write_report(out_folder(args), "peers", report, markdown(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
