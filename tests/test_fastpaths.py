"""Tracer fast paths against the plain march, to their stated tolerance.

* the cone pass (``march.cone_start``, a conservative common start depth per tile) and
  over-relaxed steps (``omega > 1`` with the safe fallback) against plain sphere tracing:
  same hits except a few silhouette pixels, depths within twice the hit band stretched by
  the incidence angle (``4 eps / cos``), fewer evaluations for the cone;
* Newton steps near the surface (``newton``) against plain sphere tracing: same hits except
  a few silhouette pixels, depths within ``4 eps / cos``, every hit point within ``eps`` of the
  isosurface, closer to a 1000x tighter plain render than plain sphere tracing at the same eps,
  and fewer evaluations;
* ``march.trace_pixels`` (a pixel subsample) equals the full render at those pixels.
"""

import numpy as np
import pytest

from smoothdist import DataMesh, SmoothDistanceField
from tracer import march
from tracer.camera import primary_rays
from tracer.render import camera_of, render, scene_arrays
from tracer.scene import scene_from_field
from test_tol import BUNNY


@pytest.fixture(scope="module")
def bunny_points():
    return SmoothDistanceField(DataMesh.load(BUNNY).as_kind("points"))


def _scene(field, size=32, eps=None, beta=0.5, alpha=200.0, alpha_u=1200.0):
    return scene_from_field(field, alpha=alpha, alpha_u=alpha_u, beta=beta, width=size,
                            height=size, eps=eps)


def _check_close(fast, plain, eps, diag):
    assert (fast.hit != plain.hit).sum() <= max(2, 0.01 * plain.hit.size)
    both = fast.hit & plain.hit
    assert both.sum() >= 40
    cos = np.abs(np.einsum("ij,ij->i", plain.normals[both], primary_rays(plain.camera)[both]))
    # a hit stops anywhere in the band d_hat <= eps (eps / cos deep along the ray), from
    # either side; Barnes-Hut's small jumps (design notes §4) widen it: 4 eps / cos
    allowed = 4.0 * eps / np.maximum(cos, 0.05) + 1e-6 * diag
    d = np.abs(fast.depth[both].astype(float) - plain.depth[both].astype(float))
    assert np.all(d <= allowed), d.max()


@pytest.mark.parametrize("case", ["bunny_points", "octopus"])
def test_cone_pass_against_plain(request, bunny_points, case):
    if case == "octopus":
        field = SmoothDistanceField(request.getfixturevalue("octopus"))
        a = field.auto_alpha()
        scene = _scene(field, eps=1e-4 * field.diagonal, alpha=a, alpha_u=3 * a)
    else:
        field = bunny_points
        scene = _scene(field, eps=1e-4 * field.diagonal)
    plain = render(scene, cone=False)
    fast = render(scene, cone=True)
    _check_close(fast, plain, scene.eps, field.diagonal)
    assert fast.steps.sum() < plain.steps.sum()


def test_over_relaxed_steps_against_plain(bunny_points):
    scene = _scene(bunny_points, eps=1e-4 * bunny_points.diagonal)
    plain = render(scene, omega=1.0, cone=False)
    for omega in (1.3, 1.9):
        fast = render(scene, omega=omega, cone=False)
        _check_close(fast, plain, scene.eps, bunny_points.diagonal)


@pytest.mark.parametrize("case", ["bunny_points", "bunny_triangles", "octopus", "tol", "beta0"])
def test_newton_steps_against_plain(request, bunny_points, case):
    if case == "octopus":
        field = SmoothDistanceField(request.getfixturevalue("octopus"))
        a = field.auto_alpha()
        kw = dict(alpha=a, alpha_u=3 * a)
    elif case == "bunny_triangles":
        field = SmoothDistanceField(DataMesh.load(BUNNY))
        kw = {}
    else:
        field = bunny_points
        kw = {"tol": dict(beta=0.0, tol=1e-2), "beta0": dict(beta=0.0)}.get(case, {})
    eps = 1e-4 * field.diagonal
    scene = scene_from_field(field, width=32, height=32, eps=eps,
                             **{"alpha": 200.0, "alpha_u": 1200.0, "beta": 0.5, **kw})
    plain = render(scene, newton=0.0)
    fast = render(scene)
    assert fast.steps.sum() < plain.steps.sum()
    # every hit is a point of the band |d| <= eps (Newton lands on either side)
    tree, roots, params, mode, lo, hi, depth_max = scene_arrays(scene)
    cam = camera_of(scene)
    rays = primary_rays(cam)
    rr, cc = np.nonzero(fast.hit)
    for r, c in list(zip(rr, cc))[::7]:
        p = cam.origin + float(fast.depth[r, c]) * rays[r, c]
        d = march.distance_at(tree, roots, params, mode, p[0], p[1], p[2], depth_max)
        assert abs(d) <= eps * (1 + 1e-3) + 1e-6 * field.diagonal, (r, c, d / eps)
    # against a plain render with a 1000x tighter eps: at least as close as plain sphere
    # tracing at the same eps (which stops up to eps / cos before the surface); on a
    # continuous field (beta = 0, tol = 0) within the band at every pixel. (Barnes-Hut and
    # tol pruning make d_hat jump where a node switches between far field and opened: a
    # march may stop at such a jump below eps, where a tighter one goes on.)
    scene.eps = 1e-7 * field.diagonal
    ref = render(scene, newton=0.0)
    if case == "beta0":
        _check_close(fast, ref, eps, field.diagonal)
    else:
        assert (fast.hit != plain.hit).sum() <= max(2, 0.01 * plain.hit.size)
    both = fast.hit & plain.hit & ref.hit
    err_fast = np.abs(fast.depth[both] - ref.depth[both]).mean()
    err_plain = np.abs(plain.depth[both] - ref.depth[both]).mean()
    assert err_fast <= err_plain


def test_trace_pixels_equals_render(bunny_points):
    scene = _scene(bunny_points, size=24)
    full = render(scene, cone=False)
    tree, roots, params, mode, lo, hi, depth_max = scene_arrays(scene)
    rows = np.array([0, 5, 11, 12, 23], dtype=np.int64)
    cols = np.array([3, 12, 12, 7, 23], dtype=np.int64)
    hit = np.zeros(5, dtype=np.bool_)
    t = np.full(5, np.nan)
    steps = np.zeros(5, dtype=np.int64)
    leaves = np.zeros(5, dtype=np.int64)
    march.trace_pixels(tree, roots, params, mode, camera_of(scene).as_array(), lo, hi,
                       float(scene.eps), int(scene.max_steps), rows, cols, depth_max, hit, t,
                       steps, leaves, march.RELAX, march.OMEGA,
                       march.newton_distance(scene.eps, lo, hi))
    np.testing.assert_array_equal(hit, full.hit[rows, cols])
    np.testing.assert_array_equal(t.astype(np.float32), full.depth[rows, cols])
    np.testing.assert_array_equal(steps, full.steps[rows, cols])
    assert hit.any()


@pytest.mark.parametrize("relax", [0.0, 0.25])
def test_cone_pass_with_tol_against_plain(bunny_points, relax):
    """tol scenes: the cone start must not let a loose first evaluation count as a hit (every
    hit is confirmed at the scene's own tol), with or without relaxed steps."""
    scene = scene_from_field(bunny_points, alpha=200.0, alpha_u=1200.0, beta=0.0, tol=1e-2,
                             width=24, height=24, eps=1e-4 * bunny_points.diagonal)
    plain = render(scene, cone=False, relax=relax)
    fast = render(scene, cone=True, relax=relax)
    _check_close(fast, plain, scene.eps, bunny_points.diagonal)
