"""Fixtures shared by the tests."""

import pytest

from zbuffer import scenes


@pytest.fixture(scope="session")
def procedural_scenes():
    """The procedural scenes every algorithm is checked on, by name."""
    return {
        "default": scenes.default_scene(),
        "boxes": scenes.overlapping_boxes(6, seed=1),
        "interpenetrating": scenes.interpenetrating_triangles(),
        "coplanar": scenes.coplanar_faces(),
        "fan": scenes.fan(32),
        "soup": scenes.random_soup(300, seed=2),
        "square": scenes.tessellated_square(9, jitter=0.3, seed=3),
    }
