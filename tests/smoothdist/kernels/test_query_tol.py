"""Tolerance-controlled evaluation (``tol``): the fast path against the plain ``beta = 0`` one.

The claim (``smoothdist._kernels.query.smooth_distance_point_tol``): with ``beta = 0`` and
``tol > 0``

    d_hat_0 - log(1 + tol) / alpha  <=  d_hat_tol  <=  d_hat_0

for every mesh and every query. Checked here

* on real meshes (the bunny as points / edges / triangles, the octopus, the trefoil), with
  and without attenuation, against ``beta = 0`` and against the brute-force sum, and that it
  visits fewer leaves than ``beta = 0``;
* on fuzzed meshes and queries (hypothesis), near and very far;
* in a forest (several objects' trees concatenated, queried from each root);
* in renders: depths against a ``beta = 0`` render, including the relaxed far-from-surface
  steps of the tracer;
* through the API, the scene format and ``tracer render --tol``.
"""

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import smoothdist
from smoothdist import DataMesh, SmoothDistanceField
from smoothdist._kernels.bvh import concatenate_trees
from smoothdist.kernels import new_stack
from smoothdist._kernels.query import smooth_distance_point_tol
from test_query_fuzz import build, meshes, queries

ROOT = Path(__file__).resolve().parents[3]
BUNNY = ROOT / "scenes" / "data" / "bunny.off"
#: float64 round-off allowance on d_hat (relative to the scene's size)
ROUND = 1e-12


def near_queries(mesh, n, rng, spread=0.05):
    """Points near the data: vertices jittered by ``spread`` x the bbox diagonal, plus a few
    farther away (up to 3 diagonals)."""
    V = mesh.V
    L = float(np.linalg.norm(V.max(0) - V.min(0)))
    Q = V[rng.integers(0, V.shape[0], n)] + rng.normal(size=(n, 3)) * spread * L
    far = V.mean(0) + rng.normal(size=(n // 10 + 1, 3)) * 3.0 * L
    return np.concatenate([Q, far]), L


def check_bound(d0, dt, alpha, tol, scale, what=""):
    err = d0 - dt
    bound = math.log1p(tol) / alpha
    slack = ROUND * (scale + np.abs(d0))
    assert np.all(err >= -slack), f"{what}: d_hat_tol above d_hat_0 by {-err.min():.3g}"
    assert np.all(err <= bound + slack), f"{what}: error {err.max():.3g} > bound {bound:.3g}"
    return err


@pytest.fixture(scope="module")
def bunny():
    return DataMesh.load(BUNNY)


@pytest.mark.parametrize("kind", ["points", "edges", "triangles"])
@pytest.mark.parametrize("tol", [1e-1, 1e-2, 1e-4])
def test_bunny_within_bound_of_beta0(bunny, kind, tol, rng):
    field = SmoothDistanceField(bunny.as_kind(kind))
    Q, L = near_queries(bunny, 300, rng)
    kw = dict(alpha=200.0, alpha_u=1200.0, gradient="exact")
    d0, g0, s0 = field.smooth_distance(Q, beta=0.0, return_stats=True, **kw)
    dt, gt, st_ = field.smooth_distance(Q, beta=0.0, tol=tol, return_stats=True, **kw)
    err = check_bound(d0, dt, 200.0, tol, L, f"{kind} tol={tol}")
    # the bound is not vacuous: the error is a sizeable part of it somewhere
    assert err.max() > 0.05 * math.log1p(tol) / 200.0
    # and it prunes: far fewer leaves than the exact sum (which visits all N)
    assert st_.leaves_visited.mean() < 0.6 * s0.leaves_visited.mean()
    assert np.all(np.isfinite(gt))


@pytest.mark.parametrize("name", ["octopus", "trefoil"])
@pytest.mark.parametrize("alpha_u", [None, 3.0])
def test_real_meshes_against_brute_force(request, name, alpha_u, rng):
    mesh = request.getfixturevalue(name)
    field = SmoothDistanceField(mesh)
    alpha = field.auto_alpha()
    Q, L = near_queries(mesh, 200, rng)
    au = None if alpha_u is None else alpha_u * alpha
    brute, _ = field.smooth_distance(Q, alpha=alpha, alpha_u=au, method="brute")
    for tol in (0.5, 1e-3):
        dt, _ = field.smooth_distance(Q, alpha=alpha, alpha_u=au, beta=0.0, tol=tol)
        check_bound(brute, dt, alpha, tol, L, f"{name} tol={tol}")


def test_tol_zero_is_the_plain_kernel(bunny, rng):
    field = SmoothDistanceField(bunny.as_kind("triangles"))
    Q, _ = near_queries(bunny, 100, rng)
    for beta in (0.0, 0.5):
        a = field.smooth_distance(Q, alpha=200.0, beta=beta, return_stats=True)
        b = field.smooth_distance(Q, alpha=200.0, beta=beta, tol=0.0, return_stats=True)
        for x, y in zip(a, b):
            np.testing.assert_array_equal(x, y)


def test_tol_with_beta_stays_below_beta0(bunny, rng):
    """Both prunings at once: only conservative (no error bound claimed)."""
    field = SmoothDistanceField(bunny.as_kind("edges"))
    Q, L = near_queries(bunny, 200, rng)
    d0, _ = field.smooth_distance(Q, alpha=200.0, beta=0.0)
    d, _ = field.smooth_distance(Q, alpha=200.0, beta=0.5, tol=1e-2)
    assert np.all(d <= d0 + ROUND * L)


def test_forest_roots(octopus, trefoil, rng):
    """Each object of a concatenated forest, queried from its root, equals its own tree."""
    fields = [SmoothDistanceField(octopus), SmoothDistanceField(trefoil)]
    forest, roots = concatenate_trees([f.tree for f in fields])
    stack, dstack = new_stack(forest)
    for f, root in zip(fields, roots):
        alpha = f.auto_alpha()
        Q, _ = near_queries(f.mesh, 30, rng)
        ref, g = f.smooth_distance(Q, alpha=alpha, beta=0.0, tol=1e-3, gradient="exact")
        for q, r, gr in zip(Q, ref, g):
            d, gx, gy, gz, _, _ = smooth_distance_point_tol(forest, q[0], q[1], q[2], alpha, 0.0,
                                                            1e-3, 1.0, 1.0 / alpha, stack,
                                                            dstack, root)
            assert d == pytest.approx(r, rel=1e-12, abs=1e-12)
            np.testing.assert_allclose([gx, gy, gz], gr, rtol=1e-9, atol=1e-12)


FUZZ = settings(max_examples=40, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.filter_too_much])


@FUZZ
@given(meshes(allow_bad_indices=False), st.data())
def test_fuzzed_conservative_and_bounded(mesh, data):
    field, _ = build(*mesh)
    assume(field is not None)
    L = field.diagonal if field.diagonal > 0 else 1.0
    alpha = 10.0 ** data.draw(st.floats(-2.0, 4.0), label="log10 alpha x L") / L
    alpha_u = data.draw(st.one_of(st.none(), st.floats(0.1, 10.0).map(lambda f: f * alpha)),
                        label="alpha_u")
    tol = 10.0 ** data.draw(st.floats(-8.0, 1.0), label="log10 tol")
    Q = queries(field, data.draw)
    d0, g0 = field.smooth_distance(Q, alpha=alpha, alpha_u=alpha_u, beta=0.0)
    dt, gt = field.smooth_distance(Q, alpha=alpha, alpha_u=alpha_u, beta=0.0, tol=tol)
    assert np.isfinite(dt).all() and np.isfinite(gt).all()
    slack = 1e-9 * (np.abs(d0) + L + 1.0 / alpha) + 1e-9 * np.abs(Q).max(axis=1)
    assert np.all(dt <= d0 + slack), (dt - d0).max()
    assert np.all(d0 - dt <= math.log1p(tol) / alpha + slack), (d0 - dt).max()


def test_bad_tol_raises(icosphere):
    field = SmoothDistanceField(icosphere)
    for bad in (-1e-3, float("nan"), float("inf"), "0.1", True):
        with pytest.raises(ValueError, match="tol"):
            field.smooth_distance([[0, 0, 2.0]], alpha=5.0, tol=bad)


def test_module_function_passes_tol(rng):
    V = rng.random((200, 3))
    Q = rng.random((20, 3)) * 2 - 0.5
    a = smoothdist.smooth_distance(Q, V, alpha=30.0, beta=0.0, tol=1e-2)
    b = SmoothDistanceField(V).smooth_distance(Q, alpha=30.0, beta=0.0, tol=1e-2)
    np.testing.assert_array_equal(a[0], b[0])


# ----------------------------------------------------------------------------- renders
def _render(field, tol, beta=0.0, size=32, eps=None, relax=None, alpha=200.0, alpha_u=1200.0):
    from tracer.rendering.renderer import render
    from tracer.scenes.scene import scene_from_field

    return render(scene_from_field(field, alpha=alpha, alpha_u=alpha_u, beta=beta, tol=tol,
                                   width=size, height=size, eps=eps), relax=relax)


def _band(result, mask, eps, bound):
    """Per-pixel allowance ``2 (eps + bound) / |cos|``: the hit band plus the value error,
    stretched along the ray by the incidence angle (``|cos| >= 0.05``)."""
    from tracer.rendering.camera import primary_rays

    cos = np.abs(np.einsum("ij,ij->i", result.normals[mask], primary_rays(result.camera)[mask]))
    return 2.0 * (eps + bound) / np.maximum(cos, 0.05)


@pytest.mark.parametrize("name", ["bunny_points", "octopus"])
def test_render_depth_against_beta0(request, bunny, name):
    """Where both hit, the tol render's depth is within the value bound plus the hit band of
    the ``beta = 0`` render's, stretched by the incidence angle (a sphere-traced hit stops
    anywhere with ``d_hat <= eps``); the masks agree except on a few silhouette pixels."""
    if name == "octopus":
        field = SmoothDistanceField(request.getfixturevalue("octopus"))
        alpha, alpha_u = field.auto_alpha(), 3 * field.auto_alpha()
    else:
        field = SmoothDistanceField(bunny.as_kind("points"))
        alpha, alpha_u = 200.0, 1200.0
    tol = 1e-2
    eps = 1e-4 * field.diagonal
    ref = _render(field, 0.0, eps=eps, alpha=alpha, alpha_u=alpha_u)
    fast = _render(field, tol, eps=eps, alpha=alpha, alpha_u=alpha_u)
    both = ref.hit & fast.hit
    assert both.sum() >= 40
    assert (ref.hit != fast.hit).sum() <= 0.01 * both.size
    allowed = _band(ref, both, eps, math.log1p(tol) / alpha)
    dt = ref.depth[both].astype(float) - fast.depth[both].astype(float)
    assert np.all(np.abs(dt) <= allowed + 1e-6 * field.diagonal), np.abs(dt).max()


def test_render_relaxed_steps_against_plain_steps(bunny):
    """The tracer's relaxed far-from-surface steps against plain steps, same tol: same hits,
    depths within the hit band (the final evaluation is always at the scene's tol)."""
    field = SmoothDistanceField(bunny.as_kind("points"))
    eps = 1e-4 * field.diagonal
    relaxed = _render(field, 1e-3, eps=eps, size=24, relax=0.25)
    plain = _render(field, 1e-3, eps=eps, size=24, relax=0.0)
    np.testing.assert_array_equal(relaxed.hit, plain.hit)
    both = relaxed.hit
    d = np.abs(relaxed.depth - plain.depth)[both]
    assert np.all(d <= _band(plain, both, eps, 0.0) + 1e-6 * field.diagonal), d.max()
    # the relaxed steps are cheaper per pixel
    assert relaxed.leaves.sum() < plain.leaves.sum()


# ----------------------------------------------------------------------------- scene, CLI
def _scene_file(tmp_path, **extra):
    data = {"camera": {"origin": [0, 0.11, 0.31], "dest": [0, 0.11, 0], "up": [0, 1, 0]},
            "objects": [{"path": str(BUNNY), "alpha": 200, "kind": "points"}],
            "width": 16, "height": 16, **extra}
    p = tmp_path / "s.json"
    p.write_text(json.dumps(data))
    return p


def test_scene_key_tol(tmp_path):
    from tracer.errors import SceneError
    from tracer.scenes.scene import load_scene

    assert load_scene(_scene_file(tmp_path)).tol == 0.0
    assert load_scene(_scene_file(tmp_path, tol=1e-3)).tol == 1e-3
    assert load_scene(_scene_file(tmp_path, tol=1e-3), {"tol": 0.5}).tol == 0.5
    for bad in (-1, "x", None):
        with pytest.raises(SceneError, match="tol"):
            load_scene(_scene_file(tmp_path, tol=bad))


@pytest.mark.slow
def test_cli_tol(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    scene = _scene_file(tmp_path)
    run = lambda *a: subprocess.run([sys.executable, "-m", "tracer", "render", str(scene), *a],
                                    cwd=tmp_path, capture_output=True, text=True, env=env,
                                    timeout=300)
    p = run("-o", "a.png", "--beta", "0", "--tol", "1e-2", "--stats", "a.json", "-q")
    assert p.returncode == 0, p.stderr
    assert json.loads((tmp_path / "a.json").read_text())["tol"] == 1e-2
    p = run("-o", "b.png", "--tol", "-1", "-q")
    assert p.returncode == 2 and p.stderr.startswith("error:") and "tol" in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1 and not (tmp_path / "b.png").exists()
