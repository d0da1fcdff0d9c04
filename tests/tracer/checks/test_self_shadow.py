"""The brute-force check of a lit render's shadows (tracer/checks/self_shadow.py, issue 46 item
3) and what it found: a pixel's shadow filled in from a single dark neighbour beside a lit
sliver (tracer.rendering.film.FILL_SHADOW_NEIGHBOURS)."""
import numpy as np
import pytest

import tracer
import tracer.rendering.film as film
from tracer.checks.self_shadow import DARK, wrongly_dark

trimesh = pytest.importorskip("trimesh")

SIZE = (64, 64)


def test_a_convex_shape_casts_no_shadow_on_itself():
    """A sphere: every pixel facing the light is clear of the sphere, so a render that put
    them in shadow (written over its shadow map here) is wrong on them, and the render itself
    on none. Not on all of them: near the terminator the sphere's own surface runs within the
    penumbra of the ray's first samples, where the check cannot tell (it never counts those)."""
    m = trimesh.creation.icosphere(subdivisions=3)
    res = tracer.render_mesh(m, size=SIZE, progress=None, lighting={"ground": False})
    got = wrongly_dark(res)
    assert got["wrong"] == 0
    res.aovs["shadow"][...] = 0.0
    got = wrongly_dark(res)
    assert got["dark"] > 500 and got["checked"] == got["dark"]
    assert got["wrong"] > 0.7 * got["dark"]


def test_an_occluded_pixel_is_not_counted():
    """A plate over a box: the box's top under the plate is truly in shadow; set dark, it is
    not counted as wrong (the rays meet the plate)."""
    box = trimesh.creation.box((1.0, 1.0, 0.2))
    plate = trimesh.creation.box((3.0, 3.0, 0.05))
    plate.apply_translation((0.0, 0.0, 0.6))
    m = trimesh.util.concatenate([box, plate])
    res = tracer.render_mesh(m, size=SIZE, progress=None, view="iso", up="z")
    base = wrongly_dark(res)
    shadow = res.aovs["shadow"]
    before = shadow.copy()
    shadow[...] = 0.0
    got = wrongly_dark(res)
    assert got["wrong"] < got["dark"]           # the plate's shadow is real ...
    assert base["wrong"] == 0 and (before < DARK).sum() > 0


def test_the_fill_rule_that_darkened_lit_pixels():
    """The coarse octopus at the defaults, 128²: filled from one neighbour, a few pixels by a
    shadow's edge came out dark with nothing in the way; from two, none
    (benchmarks/data/self_shadow.json and self_shadow_before.json: 14 shapes, 3 surfaces).
    Neighbours on both sides of the pixel (``FILL_BETWEEN``, 2026-11-28) rule those pixels
    out on their own too."""
    from benchmarks.bench_fidelity import corpus

    shape = corpus()["bunny_low"]

    def wrong(neighbours, between):
        old = film.FILL_SHADOW_NEIGHBOURS, film.FILL_BETWEEN
        try:
            film.FILL_SHADOW_NEIGHBOURS, film.FILL_BETWEEN = neighbours, between
            return wrongly_dark(tracer.render_mesh(shape, size=(128, 128), progress=None))
        finally:
            film.FILL_SHADOW_NEIGHBOURS, film.FILL_BETWEEN = old

    assert wrong(1, False)["wrong"] > 0
    assert wrong(1, True)["wrong"] == 0
    after = wrong(film.FILL_SHADOW_NEIGHBOURS, film.FILL_BETWEEN)
    assert after["wrong"] == 0 and after["checked"] > 100
