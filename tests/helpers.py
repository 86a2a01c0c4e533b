"""Helpers shared by the tests (imported by name, not through conftest)."""

import os
import threading
from pathlib import Path

import numpy as np
import pytest

import zbuffer

# ../shared/models next to the repository, or wherever ZBUFFER_MODELS points.
MODELS = Path(os.environ.get("ZBUFFER_MODELS",
                             Path(__file__).resolve().parents[2] / "shared" / "models"))


def model_names(suffix: str, fallback: str) -> list:
    """The shared models' file names ending in ``suffix`` (for
    parametrizing), or [fallback] without the folder, whose test then
    skips through model_path."""
    return sorted(p.name for p in MODELS.glob("*" + suffix)) or [fallback]


def model_path(name: str) -> Path:
    """Path of a model in the shared folder; skips the test if it is absent."""
    path = MODELS / name
    if not path.is_file():
        pytest.skip(f"model {name} not available (no {MODELS})")
    return path


def assert_same_visibility(result, reference):
    """Exact equality of depth and triangle ids (the project's contract)."""
    np.testing.assert_array_equal(result.triangle_id, reference.triangle_id)
    np.testing.assert_array_equal(result.depth, reference.depth)


# Counters every algorithm must share with the reference: what happens to a
# triangle before any algorithm-specific decision.
TRIANGLE_COUNTERS = ("triangles_in", "culled_invalid", "culled_frustum", "clipped",
                     "clipped_away", "clip_pieces", "culled_backface", "culled_degenerate")


def counters_add_up(stats) -> bool:
    s = stats
    return (s["triangles_in"] - s.get("culled_in_nodes", 0) - s["culled_invalid"]
            - s["culled_frustum"] - s["clipped"] + s["clip_pieces"]) == (
                s["culled_backface"] + s["culled_degenerate"] + s.get("culled_hidden", 0)
                + s["rasterized"])


def assert_same_counters(stats, ref_stats):
    """The shared triangle counters equal the reference's, and the triangles
    an algorithm culled as hidden plus those it drew are the ones the
    reference drew. Triangles in tree nodes culled whole (culled_in_nodes)
    never reach the vertex stage: then each counter is at most the
    reference's."""
    assert counters_add_up(stats) and counters_add_up(ref_stats)
    assert stats["triangles_in"] == ref_stats["triangles_in"]
    if stats.get("culled_in_nodes", 0) == 0:
        for key in TRIANGLE_COUNTERS:
            assert stats[key] == ref_stats[key], key
        assert stats["rasterized"] + stats["culled_hidden"] == ref_stats["rasterized"]
    else:
        for key in TRIANGLE_COUNTERS:
            assert stats[key] <= ref_stats[key], key
        assert stats["rasterized"] + stats["culled_hidden"] <= ref_stats["rasterized"]


ALGORITHMS = zbuffer.algorithms()

# Algorithms that draw a mesh's polygon faces natively: the reference does so
# too with polygons=True.
POLYGON_ALGORITHMS = frozenset(zbuffer._core.polygon_algorithms())


# Algorithms that test triangles against a Z-pyramid (test_hiz.py holds the
# registry's flag to what each algorithm does).
PYRAMID_ALGORITHMS = [a for a in ALGORITHMS if a in set(zbuffer._core.pyramid_algorithms())]


def reference_for(algo: str, mesh, **kwargs):
    """The reference render an algorithm must reproduce bit for bit."""
    return zbuffer.reference.render(mesh, polygons=algo in POLYGON_ALGORITHMS, **kwargs)
def _visits_tree_nodes(algo: str) -> bool:
    return zbuffer.render(zbuffer.scenes.default_scene(), algo=algo, width=16, height=12,
                          shading="none").stats["nodes_visited"] > 0


# The algorithms that cull whole nodes of an object-space tree: found by what
# they do, so that one registered later is not left out of the tests (nor
# out of zbuffer.Scene: test_scene.py holds the two to each other).
TREE_ALGORITHMS = [a for a in ALGORITHMS if _visits_tree_nodes(a)]


def can_render_offscreen() -> bool:
    """True if pyvista is installed and can render a picture offscreen here."""
    try:
        import pyvista as pv

        plotter = pv.Plotter(off_screen=True, window_size=(32, 32))
        plotter.add_mesh(pv.Sphere())
        image = plotter.screenshot(None)
        plotter.close()
        return image is not None and image.size > 0
    except Exception:  # no pyvista, or no OpenGL context at all
        return False


def run_in_threads(work, n: int = 4) -> list:
    """Runs ``work()`` in ``n`` threads at once; returns the exceptions they
    raised (an assertion failing in a thread would otherwise go unseen)."""
    errors = []

    def guarded():
        try:
            work()
        except Exception as err:  # (returned to the test's thread)
            errors.append(err)

    threads = [threading.Thread(target=guarded) for _ in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return errors


def spoil_a_line(draw, lines, odd_words, junk_lines):
    """For the hypothesis strategies of mesh files: one change to one of
    the file's lines (in place): a word replaced by one of ``odd_words``,
    the line dropped or repeated, or a line of ``junk_lines`` put before it."""
    from hypothesis import strategies as st

    k = draw(st.integers(0, len(lines) - 1))
    change = draw(st.sampled_from(["word", "drop", "extra", "junk"]))
    if change == "word":
        words = lines[k].split()
        if words:
            words[draw(st.integers(0, len(words) - 1))] = draw(odd_words)
        lines[k] = " ".join(words)
    elif change == "drop":
        del lines[k]
    elif change == "extra":
        lines.insert(k + 1, lines[k])
    else:
        lines.insert(k, draw(st.sampled_from(junk_lines)))


def assert_fast_path_agrees(fast, slow, clean: bool, raw: bytes, assert_same) -> None:
    """What a reader's compiled fast path owes its Python reader on one
    file: where it takes the file (``fast`` is not None), the same data or
    error (``assert_same``); where it leaves it, the file is not one of the
    common forms it must take (``clean``) that the Python reader reads --
    else a parity test could pass by taking nothing."""
    if fast is not None:
        assert_same(fast, slow)
    elif clean and not isinstance(slow, str):
        raise AssertionError(f"the fast path left a file of the forms it must take: {raw!r}")
