"""The zbuffer command line."""

import os
import subprocess
import sys

import numpy as np
import pytest
import skimage.io

import zbuffer
from zbuffer.cli import main


def test_render_default_scene(tmp_path, capsys):
    out = tmp_path / "render.png"
    depth = tmp_path / "depth.png"
    assert main(["render", "--size", "64x48", "--out", str(out), "--depth", str(depth)]) == 0
    image = skimage.io.imread(out)
    assert image.shape == (48, 64, 3) and image.dtype == np.uint8
    assert len(np.unique(image.reshape(-1, 3), axis=0)) > 10
    d = skimage.io.imread(depth)
    assert d.shape == (48, 64) and d.dtype == np.uint16 and d.max() == 65535
    text = capsys.readouterr().out
    triangles = len(zbuffer.scenes.default_scene().faces)
    assert f"default scene: {triangles:,} triangles, 64x48, algo=zbuffer" in text
    assert "pixels_written" in text


def test_render_a_file_with_options(tmp_path):
    from zbuffer import scenes
    import trimesh

    v, f = scenes.torus()
    path = tmp_path / "torus.obj"
    trimesh.Trimesh(v, f, process=False).export(path)
    out = tmp_path / "t.png"
    assert main(["render", str(path), "--algo", "zbuffer", "--size", "40x30", "--out", str(out),
                 "--projection", "orthographic", "--view-dir", "0,1,1", "--shading", "smooth",
                 "--cull-backfaces"]) == 0
    assert skimage.io.imread(out).shape == (30, 40, 3)


def test_render_writes_depth_and_ids_exactly_or_as_pictures(tmp_path):
    # .npy: the values the API returns; .png: pictures of them.
    from zbuffer import scenes
    from zbuffer.viz import id_colors

    files = {k: str(tmp_path / k) for k in ("d.npy", "i.npy", "d.png", "i.png")}
    for depth, ids in (("d.npy", "i.npy"), ("d.png", "i.png")):
        assert main(["render", "--size", "64x48", "--out", "none", "--algo", "hiz",
                     "--depth", files[depth], "--ids", files[ids]]) == 0
    res = zbuffer.render(scenes.default_scene(), camera=scenes.default_camera(64 / 48),
                         width=64, height=48, shading="none")
    np.testing.assert_array_equal(np.load(files["i.npy"]), res.triangle_id)
    np.testing.assert_array_equal(np.load(files["d.npy"]), res.eye_depth())
    assert np.load(files["i.npy"]).dtype == np.int32
    np.testing.assert_array_equal(skimage.io.imread(files["i.png"]), id_colors(res.triangle_id))
    grey = skimage.io.imread(files["d.png"])
    assert grey.dtype == np.uint16 and ((grey == 0) == ~res.mask).all()


@pytest.mark.parametrize("args, message", [
    (["render", "missing.obj"], "no such mesh file"),
    (["render", "--out", "none", "--ids", "ids.jpg"], "must end in .png, .npy"),
    (["render", "--algo", "painter", "--out", "none"], "unknown algorithm 'painter'"),
    (["render", "--fov", "0", "--out", "none"], "fov_y must be in (0, 180)"),
    (["render", "--out", ""], "is not a file name"),
    (["render", "--out", "."], "is not a file name"),
    (["render", "--out", "picture.xyz"], "must end in .png"),
    (["render", "--out", "no/such/folder/t.png"], "no folder"),
    (["render", "--out", "none", "--depth", "d.jpg"], "must end in .png, .npy"),
    (["render", "--out", "x.png", "--ids", "./x.png"], "--out and --ids name the same file"),
    (["render", "--out", "none", "--depth", "x.npy", "--ids", "x.npy"],
     "--depth and --ids name the same file"),
    (["render", "--out", "none", "--target", "1,1,1"], "--target needs --eye"),
    (["render", "--out", "none", "--near", "0.5"], "--near and --far need --eye"),
    (["render", "--out", "none", "--eye", "0,0,3", "--near", "2", "--far", "1"], "near"),
    (["render", "--out", "none", "--eye", "0,0,3", "--view-dir", "1,0,0"],
     "--view-dir and --eye both place the camera"),
])
def test_errors_are_reported_not_raised(args, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(args) == 2
    assert message in capsys.readouterr().err
    assert not list(tmp_path.iterdir())  # refused before anything was written


def test_an_unreadable_file_is_reported_not_raised(tmp_path, capsys, monkeypatch):
    # A fuzzer's find: an OSError other than "no such file" (here EIO, from a
    # mesh file that is really /proc/self/mem) came out as a traceback.
    if not os.path.exists("/proc/self/mem"):
        pytest.skip("needs Linux's /proc/self/mem")
    (tmp_path / "x.obj").symlink_to("/proc/self/mem")
    monkeypatch.chdir(tmp_path)
    assert main(["render", "x.obj", "--out", "none"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("zbuffer: error: ") and "Traceback" not in err


def test_output_cut_short_by_a_closed_pipe_is_quiet():
    # `zbuffer render ... | head -1` printed a BrokenPipeError traceback.
    code = "import sys; from zbuffer.cli import main; sys.exit(main(sys.argv[1:]))"
    with subprocess.Popen([sys.executable, "-c", code, "render", "--out", "none", "--size",
                           "32x24"], stdout=subprocess.PIPE, stderr=subprocess.PIPE) as proc:
        proc.stdout.close()  # before it writes a line
        err = proc.stderr.read().decode()
        assert proc.wait() == 1
    assert err == ""


def test_files_are_written_whatever_happens_to_the_report(tmp_path):
    # The report printed before the files were written: with unbuffered
    # output, a closed pipe stopped the command before them.
    code = "import sys; from zbuffer.cli import main; sys.exit(main(sys.argv[1:]))"
    files = [tmp_path / "a.png", tmp_path / "a_depth.png", tmp_path / "a_ids.npy"]
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    with subprocess.Popen([sys.executable, "-c", code, "render", "--size", "32x24",
                           "--out", str(files[0]), "--depth", str(files[1]), "--ids", str(files[2])],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env) as proc:
        proc.stdout.close()
        assert proc.stderr.read().decode() == ""
        assert proc.wait() == 1
    assert all(f.exists() for f in files)
    assert np.load(files[2]).shape == (24, 32)


@pytest.mark.parametrize("size, message", [("big", "size must look like 800x600"),
                                           ("0x10", "must be positive"),
                                           ("5x0", "must be positive")])
def test_bad_size_is_a_usage_error(size, message, capsys):
    with pytest.raises(SystemExit):
        main(["render", "--size", size])
    assert message in capsys.readouterr().err


def test_algorithms_lists_the_registry(capsys):
    assert main(["algorithms"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines] == zbuffer.algorithms()
    assert all(len(line.split()) > 1 for line in lines)  # each with its summary


def test_version_is_the_installed_distributions(capsys):
    from importlib.metadata import version

    with pytest.raises(SystemExit) as done:
        main(["--version"])
    assert done.value.code == 0
    assert capsys.readouterr().out.strip() == f"zbuffer {version('zbuffer')}"


@pytest.mark.skipif(__import__("sys").platform in ("win32", "darwin"), reason="always has a display")
def test_view_without_a_display_asks_for_a_screenshot(monkeypatch, capsys):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["view", "--size", "32x24"]) == 2
    assert "use --screenshot FILE" in capsys.readouterr().err


def test_bench_finds_the_checkouts_harness(monkeypatch, tmp_path):
    from pathlib import Path

    from zbuffer.cli import find_benchmarks

    repo = Path(__file__).resolve().parents[1]
    monkeypatch.delenv("ZBUFFER_BENCHMARKS", raising=False)
    monkeypatch.chdir(repo / "tests")  # from inside the checkout, one level down
    assert find_benchmarks().resolve() in {repo / "benchmarks",
                                           Path(__import__("zbuffer").__file__).resolve().parents[2]
                                           / "benchmarks"}
    monkeypatch.setenv("ZBUFFER_BENCHMARKS", str(repo / "benchmarks"))
    assert find_benchmarks() == repo / "benchmarks"


def test_bench_outside_a_checkout_says_what_it_needs(monkeypatch, tmp_path, capsys):
    from zbuffer import cli

    monkeypatch.setenv("ZBUFFER_BENCHMARKS", str(tmp_path))
    assert main(["bench", "--quick"]) == 2
    assert "not a zbuffer benchmarks folder" in capsys.readouterr().err
    # An installed package, run from a folder outside any checkout.
    monkeypatch.delenv("ZBUFFER_BENCHMARKS")
    monkeypatch.setattr(cli, "__file__", str(tmp_path / "site" / "zbuffer" / "cli.py"))
    monkeypatch.chdir(tmp_path)
    assert cli.find_benchmarks() is None
    assert main(["bench", "--quick"]) == 2
    assert "source checkout" in capsys.readouterr().err


@pytest.mark.parametrize("args, message", [
    (["bench", "nope", "--quick"], "unknown benchmark suite 'nope'"),
    (["bench", "render", "--quick", "--out", ""], "is not a folder"),
    (["bench", "render", "--quick", "--out", "a_file"], "is not a folder"),
    (["bench", "render", "--quick", "--out", "a_file/below"], "cannot make that folder"),
])
def test_bench_checks_its_arguments_before_running(args, message, monkeypatch, tmp_path, capsys):
    # Refused up front (nothing run, a zbuffer: error), not after the suites.
    from pathlib import Path

    from zbuffer import cli

    monkeypatch.setenv("ZBUFFER_BENCHMARKS", str(Path(__file__).resolve().parents[1] / "benchmarks"))
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a_file").write_text("")
    monkeypatch.setattr(__import__("subprocess"), "run", lambda *a, **k: pytest.fail("ran"))
    assert main(args) == 2
    assert message in capsys.readouterr().err


def test_render_takes_up_on_the_built_in_scene():
    # --up used to be ignored for the built-in scene's default camera; it
    # turns that view, which is framed again: the whole scene in the picture.
    from zbuffer.cli import build_parser, render_camera

    mesh = zbuffer.scenes.default_scene()
    for up in [(0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 2.0, 0.0), (1.0, 1.0, 1.0)]:
        args = build_parser().parse_args(["render", "--up", ",".join(map(str, up))])
        camera = render_camera(args, mesh, 800, 600)
        expected = zbuffer.scenes.default_camera(800 / 600, up=up)
        assert camera == expected and camera.up == tuple(up)
        mvp = camera.resolve(mesh).mvp(800, 600)
        clip = np.c_[mesh.vertices, np.ones(len(mesh.vertices))] @ mvp.T
        extent = np.abs(clip[:, :2] / clip[:, 3:]).max(axis=0)
        assert extent.max() == pytest.approx(0.9, abs=0.01) and extent.min() <= 0.9 + 1e-9


@pytest.mark.parametrize("option", [["--fov", "45"], ["--projection", "perspective"],
                                    ["--view-dir", "0,0,1"]])
def test_render_view_options_given_frame_the_built_in_scene(option):
    # Giving a view option takes the built-in scene off its own view, even
    # with the option's default value (it used to be told by the value).
    from zbuffer.cli import build_parser, render_camera

    mesh = zbuffer.scenes.default_scene()
    own = render_camera(build_parser().parse_args(["render"]), mesh, 800, 600)
    assert own == zbuffer.scenes.default_camera(800 / 600)
    camera = render_camera(build_parser().parse_args(["render", *option]), mesh, 800, 600)
    assert camera == zbuffer.Camera.fit(mesh, aspect=800 / 600)
    assert camera != own


def test_render_takes_clip_planes_with_eye():
    # --near and --far set the camera's clip planes (fitted to the mesh
    # otherwise), so that a mesh the camera cannot frame by itself (the
    # error says to set them) can still be rendered from the CLI.
    from zbuffer.cli import build_parser, render_camera

    mesh = zbuffer.Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float) * 1e151, [[0, 1, 2]])
    eye = ["--eye", "1e150,1e150,3e151", "--target", "1e150,1e150,0"]
    args = build_parser().parse_args(["render", *eye, "--near", "1e151", "--far", "5e151"])
    camera = render_camera(args, mesh, 64, 48)
    assert (camera.near, camera.far) == (1e151, 5e151)
    res = zbuffer.render(mesh, camera=camera, width=64, height=48, shading="none")
    ref = zbuffer.reference.render(mesh, camera=camera, width=64, height=48, shading="none")
    assert res.mask.any()
    np.testing.assert_array_equal(res.depth, ref.depth)
    args = build_parser().parse_args(["render", *eye])
    with pytest.raises(ValueError, match="give the camera near and far"):
        zbuffer.render(mesh, camera=render_camera(args, mesh, 64, 48), width=64, height=48)


def test_render_says_which_options_set_what_a_huge_mesh_needs(tmp_path, capsys):
    path = tmp_path / "huge.obj"
    path.write_text("v 0 0 0\nv 1e300 0 0\nv 0 1e300 0\nf 1 2 3\n")
    assert main(["render", str(path), "--out", "none"]) == 2
    assert capsys.readouterr().err.endswith(
        "; pass a camera (here: --eye, --target, --near and --far)\n")
    assert main(["render", str(path), "--out", "none", "--eye", "0,0,3"]) == 2  # (no centre)
    assert capsys.readouterr().err.endswith("(here: --eye, --target, --near and --far)\n")
    assert main(["render", str(path), "--out", "none", "--eye", "0,0,3", "--target", "0,0,0"]) == 2
    assert capsys.readouterr().err.endswith(
        "; give the camera near and far instead of leaving them to be fitted "
        "(here: --near and --far)\n")
    assert main(["render", str(path), "--out", "none", "--eye", "0,0,3", "--target", "0,0,0",
                 "--near", "0.1", "--far", "10"]) == 0


def test_bench_knows_the_harness_suites():
    # zbuffer bench checks suite names itself (before running anything):
    # its list is benchmarks/run.py's.
    import sys
    from pathlib import Path

    from zbuffer.cli import BENCH_SUITES

    folder = Path(__file__).resolve().parents[1] / "benchmarks"
    sys.path.insert(0, str(folder))
    try:
        import run
    finally:
        sys.path.remove(str(folder))
    assert BENCH_SUITES == tuple(run.SUITES)


def test_options_reach_the_render_and_depth_pngs_are_nearest_white(tmp_path, capsys):
    # (test_render_a_file_with_options checks only the picture's shape.)
    soup = zbuffer.scenes.random_soup(200, seed=5)
    path = tmp_path / "soup.obj"
    path.write_text("".join("v %r %r %r\n" % tuple(map(float, p)) for p in soup.vertices)
                    + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in soup.faces))
    ids, depth = tmp_path / "ids.npy", tmp_path / "d.png"
    assert main(["render", str(path), "--algo", "scanline", "--size", "40x30", "--out", "none",
                 "--projection", "orthographic", "--view-dir", "0,1,1", "--cull-backfaces",
                 "--ids", str(ids), "--depth", str(depth)]) == 0
    assert "algo=scanline" in capsys.readouterr().out
    mesh = zbuffer.load(path)
    cam = zbuffer.Camera.fit(mesh, direction=(0, 1, 1), projection="orthographic", aspect=40 / 30)
    res = zbuffer.render(mesh, camera=cam, width=40, height=30, cull_backfaces=True,
                         shading="none")
    assert res.stats["culled_backface"] > 0
    np.testing.assert_array_equal(np.load(ids), res.triangle_id)
    grey = skimage.io.imread(depth).astype(int)
    eye = res.eye_depth()
    assert grey[np.unravel_index(np.argmin(eye), eye.shape)] == 65535
    assert grey[np.unravel_index(np.argmax(np.where(res.mask, eye, -1)), eye.shape)] == 8192


def test_an_eye_without_a_target_looks_at_the_mesh_centre():
    from zbuffer.cli import build_parser, render_camera

    mesh = zbuffer.Mesh(*zbuffer.scenes.box((5, 6, 7), (1, 1, 1)))
    args = build_parser().parse_args(["render", "x.obj", "--eye", "0,0,0"])
    assert render_camera(args, mesh, 64, 48).target == (5.0, 6.0, 7.0)


def test_a_smoke_run_of_the_benchmarks_does_not_write_over_the_record():
    # `zbuffer bench --quick` wrote its few small inputs' numbers into
    # benchmarks/results, the recorded results.
    import argparse
    import importlib.util
    from pathlib import Path

    folder = Path(__file__).resolve().parents[1] / "benchmarks"
    spec = importlib.util.spec_from_file_location("bench_common", folder / "common.py")
    common = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(common)
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true")
    common.add_out_argument(parser)
    assert common.out_folder(parser.parse_args([])) == folder / "results"
    quick = common.out_folder(parser.parse_args(["--quick"]))
    assert quick != folder / "results" and "build" in quick.parts
    assert common.out_folder(parser.parse_args(["--quick", "--out", "x"])) == Path("x")
