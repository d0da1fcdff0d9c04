"""The ripple metric (tracer/rendering/ripple.py): its shapes' normals and the angles it reports.

The analytic normals are checked against central differences of each shape's own distance
function (and the curves' closest points against dense sampling and the library's exact
distance); the metric against renders whose answer is known: the exact offset surface of one
point is a sphere (angles ~0), and the same normals turned by a known angle give that angle.
"""

import numpy as np
import pytest

from smoothdist import DataMesh, SmoothDistanceField
from tracer.rendering import ripple as rp
from tracer.scenes.scene import scene_from_field
from tracer.rendering.renderer import render

RNG = np.random.default_rng(35)


@pytest.fixture(autouse=True)
def _seeded():
    """Every test draws the same points whichever tests run before it."""
    global RNG
    RNG = np.random.default_rng(35)


def fd_normals(shape, P, h=1e-6):
    """Unit central-difference gradients of ``shape.distance``."""
    G = np.empty_like(P)
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        G[:, k] = (shape.distance(P + e) - shape.distance(P - e)) / (2 * h)
    return G / np.linalg.norm(G, axis=1, keepdims=True)


def near(shape_points, scale=0.2):
    """Points within ``scale`` of given surface points, off the surface."""
    return shape_points + RNG.uniform(-scale, scale, shape_points.shape)


def _helix_and_samples():
    h = rp.Helix(1.0, 0.8, 2)
    return h, near(h.point(RNG.uniform(0.3, 2 * np.pi * 2 - 0.3, 300)), 0.15)


SHAPES = {
    "sphere": lambda: (rp.Sphere(0.7, (0.1, 0.2, 0.3)), near(RNG.normal(size=(300, 3)), 1.0)),
    "capsule": lambda: (rp.Capsule((0, 0, -0.5), (0.2, 0, 0.5), 0.4),
                        RNG.uniform(-1.2, 1.2, (300, 3))),
    "torus": lambda: (rp.Torus(1.0, 0.3), near(np.c_[np.cos(t := RNG.uniform(0, 6.28, 300)),
                                                        np.sin(t), np.zeros(300)], 0.25)),
    "box": lambda: (rp.Box((1.0, 0.75, 0.5)), RNG.uniform(-1.6, 1.6, (300, 3))),
    "rounded_cube": lambda: (rp.RoundedCube(1.0, samples=120),
                             near(_on_cube(300), 0.2)),
    "helix": _helix_and_samples,
}


def _on_cube(n):
    C = RNG.uniform(-1, 1, (n, 3))
    k = RNG.integers(0, 3, n)
    C[np.arange(n), k] = np.sign(C[np.arange(n), k])
    return C / (np.sum(C ** 4, axis=1) ** 0.25)[:, None]


@pytest.mark.parametrize("name", list(SHAPES))
def test_shape_normals_are_the_gradients_of_their_distance(name):
    shape, P = SHAPES[name]()
    d = shape.distance(P)
    keep = np.abs(d) > 1e-3           # off the surface (or the curve) itself
    if name == "box":                 # inside, the nearest face is ambiguous where two tie
        Q = np.abs(P) - shape.half
        top2 = np.sort(Q, axis=1)
        keep &= (top2[:, 2] - top2[:, 1] > 1e-3) | np.any(Q > 0, axis=1)
    got = shape.normals(P[keep])
    ref = fd_normals(shape, P[keep])
    # (the metric reports whole degrees; central differences are good to ~1e-3 degrees
    # except near a ridge of the distance, inside the rounded cube's edges)
    angles = np.degrees(np.arccos(np.clip(np.sum(got * ref, axis=1), -1, 1)))
    assert angles.max() < 0.1 and np.median(angles) < 1e-3


def test_rounded_cube_is_pyvistas_superellipsoid_and_its_closest_points_are_closest():
    pv = pytest.importorskip("pyvista")
    m = pv.ParametricSuperEllipsoid(n1=0.5, n2=0.5)
    V = np.asarray(m.points, float)
    np.testing.assert_allclose(np.sum(V ** 4, axis=1), 1.0, atol=1e-5)
    cube = rp.RoundedCube(1.0, samples=120)
    P = near(_on_cube(200), 0.3)
    Q = cube.closest(P)
    np.testing.assert_allclose(np.sum(Q ** 4, axis=1), 1.0, atol=1e-9)
    # no point of a dense, independent sample of the surface is closer
    d_dense = np.min(np.linalg.norm(P[:, None] - V[None], axis=2), axis=1)
    assert np.all(np.linalg.norm(P - Q, axis=1) <= d_dense + 1e-9)


def test_curves_closest_points_match_the_librarys_exact_distance():
    h = rp.Helix(1.0, 0.8, 2)
    s = np.linspace(0, 4 * np.pi, 4001)
    poly = DataMesh(h.point(s), np.c_[np.arange(4000), np.arange(1, 4001)])
    P = near(h.point(RNG.uniform(0, 4 * np.pi, 200)), 0.3)
    d_lib = SmoothDistanceField(poly).exact_distance(P)[0]
    # the 4000-segment polyline is within its sagitta (~1e-6) of the helix
    np.testing.assert_allclose(h.distance(P), d_lib, atol=2e-6)
    V = RNG.normal(size=(10, 3))
    E = np.array([[0, 1], [1, 2], [3, 4], [5, 6], [6, 7], [8, 9]])
    seg = rp.Segments(V, E)
    Q = RNG.normal(size=(300, 3)) * 2
    np.testing.assert_allclose(seg.distance(Q),
                               SmoothDistanceField(DataMesh(V, E)).exact_distance(Q)[0],
                               atol=1e-12)


def _one_point_render(r=0.5, size=48):
    c = np.array([0.1, -0.2, 0.3])
    field = SmoothDistanceField(c[None, :])
    scene = scene_from_field(field, alpha=1.0 / r, mode="exact", offset=r, eps=1e-7,
                             width=size, height=size,
                             camera=(c + [0.4, 0.5, 2.0], c, [0, 1, 0]))
    return render(scene), rp.Sphere(r, c), field


def test_exact_sphere_has_no_ripple_and_its_mean_offset_is_its_radius():
    res, sphere, field = _one_point_render()
    out = rp.ripple(res, sphere)
    assert out["hits"] > 300
    assert out["p50"] < 0.01 and out["p95"] < 0.05
    assert rp.mean_offset(res, field) == pytest.approx(0.5, abs=1e-6)
    # 3000 random samples of a sphere at an offset of 15 spacings: a union of balls, nearly
    # a sphere (about 2 degrees at the median, from creases between the balls); the same
    # normals against a sphere about another centre are several times farther off
    P = RNG.normal(size=(3000, 3))
    P /= np.linalg.norm(P, axis=1, keepdims=True)
    scene = scene_from_field(SmoothDistanceField(P), alpha=1.0, mode="exact", offset=1.0,
                             width=48, height=48, view="iso")
    res = render(scene)
    out = rp.ripple(res, rp.Sphere(2.0))
    assert out["p50"] < 2.5 and out["p95"] < 5.0
    moved = rp.ripple(res, rp.Sphere(2.0, (0.3, 0.0, 0.0)))
    assert moved["p50"] > 2 * out["p50"] + 2.0


@pytest.mark.parametrize("turn", [5.0, 20.0])
def test_wrong_normals_give_their_angle(turn):
    res, sphere, _ = _one_point_render()
    N = res.normals.copy()
    # turn every hit normal by `turn` degrees about an axis perpendicular to it
    n = N[res.hit]
    axis = np.cross(n, RNG.normal(size=n.shape))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    a = np.radians(turn)
    N[res.hit] = n * np.cos(a) + np.cross(axis, n) * np.sin(a)
    out = rp.ripple(res._replace(normals=N), sphere)
    assert out["p50"] == pytest.approx(turn, abs=0.05)
    assert out["p95"] == pytest.approx(turn, abs=0.05)
    # and the wrong shape: a sphere about another centre
    far = rp.ripple(_one_point_render()[0], rp.Sphere(0.5, sphere.centre + [0.3, 0, 0]))
    assert far["p95"] > 20.0
