"""Rigid-body simulation: mass properties, integrator, interior-point solver, contact.

Every expected value comes from an independent computation: trimesh's mass properties, closed
forms (parabola, discrete implicit Euler, conserved angular momentum), a bisection of the
library's point-query smooth distance, finite differences, or the exact distance.
"""

import numpy as np
import pytest
import trimesh

from smoothdist import DataMesh, SmoothDistanceField
from tracer.errors import InfeasibleStart
from tracer.sim import ipm, primitives
from tracer.sim.bodies import Body, left_jacobian, mass_properties, rotation_matrix
from tracer.sim.constraint import ContactConstraint
from tracer.sim.integrator import Integrator

G = np.array([0.0, 0.0, -9.81])


# ---------------------------------------------------------------------- mass properties
def test_mass_properties_of_closed_mesh_match_trimesh():
    tm = trimesh.creation.box(extents=[1.0, 2.0, 0.5])
    tm.apply_transform(trimesh.transformations.rotation_matrix(0.7, [1, 2, 3], [0.3, 0.1, 0]))
    tm.apply_translation([0.4, -1.0, 2.0])
    m, com, inertia = mass_properties(DataMesh(tm.vertices, tm.faces), density=3.0)
    tm.density = 3.0
    assert m == pytest.approx(tm.mass, rel=1e-12)
    np.testing.assert_allclose(com, tm.center_mass, atol=1e-12)
    np.testing.assert_allclose(inertia, tm.moment_inertia, atol=1e-12)


def test_mass_properties_of_wire_ring_and_points():
    n, r = 400, 0.7
    s = np.linspace(0, 2 * np.pi, n, endpoint=False)
    V = np.c_[r * np.cos(s), r * np.sin(s), np.zeros(n)]
    E = np.c_[np.arange(n), (np.arange(n) + 1) % n]
    m, com, inertia = mass_properties(DataMesh(V, E), density=2.0)
    L = n * 2 * r * np.sin(np.pi / n)                  # polygon perimeter
    assert m == pytest.approx(2.0 * L, rel=1e-12)
    # thin ring: I_zz = m r^2, I_xx = I_yy = m r^2 / 2 (to the polygon's discretisation)
    np.testing.assert_allclose(np.diag(inertia), m * r * r * np.array([0.5, 0.5, 1.0]), rtol=1e-4)
    P = np.random.default_rng(0).normal(size=(50, 3))
    m, com, inertia = mass_properties(DataMesh(P), density=0.5)
    Q = P - P.mean(axis=0)
    expect = 0.5 * (np.sum(Q * Q) * np.eye(3) - Q.T @ Q)
    assert m == 25.0
    np.testing.assert_allclose(inertia, expect, atol=1e-12)


def test_single_point_gets_a_definite_inertia():
    m, com, inertia = mass_properties(DataMesh(np.zeros((1, 3))), density=2.0)
    assert m == 2.0 and np.all(np.linalg.eigvalsh(inertia) > 0)


def test_rotation_jacobian_matches_finite_differences():
    rng = np.random.default_rng(1)
    w = rng.normal(size=3)
    y = rng.normal(size=3)
    J = left_jacobian(w)
    num = np.empty((3, 3))
    for a in range(3):
        e = np.zeros(3)
        e[a] = 1e-6
        num[:, a] = (rotation_matrix(w + e) @ y - rotation_matrix(w - e) @ y) / 2e-6
    R = rotation_matrix(w)
    Ry = R @ y
    K = np.array([[0, -Ry[2], Ry[1]], [Ry[2], 0, -Ry[0]], [-Ry[1], Ry[0], 0]])
    np.testing.assert_allclose(num, -K @ J, atol=1e-8)


# ---------------------------------------------------------------------- helpers
def _point_cloud_distance():
    """The stand-in of tests/sim_standin.py (point-cloud query meshes)."""
    from tests.sim_standin import PointQueryDistance

    return PointQueryDistance


def _plane_and(body_mesh, z, alpha=30.0, factory=None, **kw):
    plane = Body.from_mesh(primitives.make({"type": "plane", "size": [3, 3], "resolution": 3}),
                           name="plane", alpha=alpha, static=True)
    body = Body.from_mesh(body_mesh, name="body", alpha=alpha, position=[0, 0, z], **kw)
    con = ContactConstraint([plane, body], beta=0.5, factory=factory)
    return plane, body, con


# ---------------------------------------------------------------------- integrator
def test_free_flight_is_the_discrete_parabola():
    mesh = primitives.make({"type": "sphere_points", "radius": 0.2, "count": 30})
    plane, body, con = _plane_and(mesh, z=50.0, factory=_point_cloud_distance())
    x0 = body.x.copy()
    v0 = np.array([1.0, -0.5, 4.0])
    body.v = v0.copy()
    h = 0.01
    sim = Integrator([plane, body], con, G, h)
    for n in range(1, 101):
        st = sim.step()
        assert st.iterations == 0                      # the unconstrained step is feasible
        t = n * h
        discrete = x0 + t * v0 + h * h * G * n * (n + 1) / 2   # implicit Euler, closed form
        np.testing.assert_allclose(body.x, discrete, atol=1e-10)
        # first order: the gap to the analytic parabola is h t |g| / 2
        analytic = x0 + t * v0 + 0.5 * G * t * t
        assert np.linalg.norm(body.x - analytic) == pytest.approx(0.5 * h * t * 9.81, rel=1e-6)


def test_torque_free_spin_keeps_angular_momentum():
    box = primitives.make({"type": "box", "size": [0.3, 0.6, 1.0]})
    far = primitives.make({"type": "point"})
    anchor = Body.from_mesh(far, name="anchor", alpha=10.0, static=True, position=[100, 0, 0])
    body = Body.from_mesh(box, name="box", alpha=10.0, angular_velocity=[3.0, 0.4, 1.0])
    con = ContactConstraint([anchor, body])
    sim = Integrator([anchor, body], con, np.zeros(3), 0.005)
    L0 = body.angular_momentum()
    E0 = body.kinetic_energy()
    energies = []
    for _ in range(200):
        sim.step()
        np.testing.assert_allclose(body.angular_momentum(), L0, rtol=1e-9, atol=1e-12)
        energies.append(body.kinetic_energy())
    # exponential Euler is first order: the rotational energy drifts by O(h) (stated: 5%)
    assert np.max(np.abs(np.array(energies) - E0)) < 0.05 * E0
    np.testing.assert_allclose(body.R @ body.R.T, np.eye(3), atol=1e-12)


def _rest_height_of_point(alpha):
    """z where the plane's smooth distance to the point (0, 0, z) is 0 (bisection)."""
    plane = primitives.make({"type": "plane", "size": [3, 3], "resolution": 3})
    f = SmoothDistanceField(plane)
    lo, hi = 0.0, 1.0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        d = f.smooth_distance([[0, 0, mid]], alpha=alpha, beta=0.5, alpha_u=alpha)[0][0]
        lo, hi = (mid, hi) if d <= 0 else (lo, mid)
    return 0.5 * (lo + hi), f.inflation(alpha, alpha)


def test_point_mass_comes_to_rest_on_the_smooth_surface():
    alpha = 30.0
    z_rest, inflation = _rest_height_of_point(alpha)
    assert 0 < z_rest <= inflation
    # the paper's alpha-metric gradient: with the true derivative (the stand-in's default, as
    # the simulator's) the plane's zero set is a dome (more triangles sum up under its centre)
    # whose top is tilted by the grid's diagonals, and the point slides off the plane; with the
    # metric the weights' horizontal pull is 30x weaker and (0, 0) a rest point for 60 steps
    standin = _point_cloud_distance()

    def metric(*args, **kw):
        return standin(*args, **{**kw, "gradient": "metric"})

    plane, body, con = _plane_and(primitives.make({"type": "point"}), z=0.4, alpha=alpha,
                                  factory=metric)
    sim = Integrator([plane, body], con, G, 0.01)
    energy = []
    seen = []
    sim.on_iterate = lambda q, c: seen.append(c)
    for _ in range(60):                 # (0, 0) is an unstable rest point of the grid's surface
        st = sim.step()
        assert st.min_c > 0
        energy.append(0.5 * body.mass * body.v @ body.v - body.mass * G @ body.x)
        if st.iterations == 0:
            assert len(energy) < 2 or energy[-1] <= energy[-2] + 1e-12   # free flight
    assert seen and min(seen) > 0
    # at rest on the zero set of the plane's smooth distance, within the solver's gap
    # tolerance (1e-2 / alpha) plus 1e-4
    assert sim.gap_tol == pytest.approx(1e-2 / alpha)
    assert body.x[2] == pytest.approx(z_rest, abs=sim.gap_tol + 1e-4)
    assert np.linalg.norm(body.v) < 0.01
    assert energy[-1] < energy[0]


def test_point_sphere_rests_between_radius_and_radius_plus_inflation():
    mesh = primitives.make({"type": "sphere_points", "radius": 0.25, "count": 40})
    plane, body, con = _plane_and(mesh, z=0.45, alpha=30.0)      # smoothdist.MeshDistance
    sim = Integrator([plane, body], con, G, 0.01)
    for _ in range(80):
        sim.step()
    X, Rs = sim.current()
    # the lowest point of the sphere is above the plane: exact gap > 0 ...
    lowest = (body.mesh.V @ body.R.T + body.x)[:, 2].min()
    assert lowest > 0
    assert con.min_exact_distance(X, Rs) == pytest.approx(lowest, abs=1e-9)
    # ... and below the conservative bound of both LogSumExps
    p = con.pairs[0]
    assert lowest <= p.inflation
    assert abs(body.v[2]) < 0.1


# ---------------------------------------------------------------------- solver
def test_ipm_projects_onto_a_sphere_and_every_iterate_is_feasible():
    xhat = np.array([0.3, -0.2, 0.1])                 # inside the unit ball: infeasible
    x0 = np.array([2.0, 0.0, 0.0])
    seen = []

    def con(x):
        r = np.linalg.norm(x)
        return r - 1.0, x / r

    res = ipm.solve(x0, lambda x: (0.5 * (x - xhat) @ (x - xhat), x - xhat),
                    lambda x: np.eye(3), con, mu0=0.1, mu_min=1e-10, tol=1e-10,
                    on_iterate=lambda x, c: seen.append(c))
    assert res.converged
    np.testing.assert_allclose(res.x, xhat / np.linalg.norm(xhat), atol=1e-6)
    assert min(seen) > 0 and res.min_c > 0
    # multiplier: grad E = z grad c at the solution
    assert res.z == pytest.approx(1.0 - np.linalg.norm(xhat), rel=1e-4)


def test_ipm_refuses_an_infeasible_start():
    with pytest.raises(InfeasibleStart):
        ipm.solve(np.zeros(3), lambda x: (0.0, 0 * x), lambda x: np.eye(3),
                  lambda x: (-1.0, np.ones(3)), mu0=1, mu_min=1e-6, tol=1e-6)


def test_every_iterate_is_feasible_near_contact():
    """A fast box (points) thrown at a plane a hair away: all iterates and trial points > 0."""
    mesh = primitives.make({"type": "box", "size": [0.4, 0.3, 0.2]}).as_kind("points")
    plane, body, con = _plane_and(mesh, z=0.0, alpha=40.0, factory=_point_cloud_distance(),
                                  rotation=rotation_matrix([0.3, 0.2, 0.0]),
                                  velocity=[0.5, 0, -3.0], angular_velocity=[2, 0, 1])
    # lift the box until its constraint is just positive
    X, Rs = np.array([plane.x, body.x]), np.array([plane.R, body.R])
    for _ in range(200):
        c = con.evaluate(X, Rs, gradient=False)[0]
        if c > 1e-3:
            break
        X[1, 2] += 2e-3
    body.x = X[1].copy()
    sim = Integrator([plane, body], con, G, 0.01)
    seen = []
    sim.on_iterate = lambda q, c: seen.append(c)
    for _ in range(10):
        st = sim.step()
        assert st.min_c > 0 and st.c > 0
    assert len(seen) > 10 and min(seen) > 0
    assert con.min_exact_distance(*sim.current()) > 0


def test_constraint_gradient_matches_finite_differences():
    cloud = DataMesh(np.random.default_rng(2).normal(size=(40, 3)) * 0.3)
    other = primitives.make({"type": "sphere_points", "radius": 0.3, "count": 25})
    a = Body.from_mesh(cloud, name="a", alpha=5.0, position=[0, 0, 0])
    b = Body.from_mesh(other, name="b", alpha=4.0, position=[0.9, 0.4, 0.2],
                       rotation=rotation_matrix([0.2, -0.4, 0.9]))
    from tests.sim_standin import PointQueryDistance

    con = ContactConstraint([a, b], beta=0.0, factory=PointQueryDistance)
    sim = Integrator([a, b], con, G, 0.01)
    X0, R0 = sim.current()
    q = np.r_[a.x, [0.1, -0.2, 0.3], b.x, [-0.3, 0.2, 0.05]]
    c, g = sim.constraint_at(q, X0, R0)
    num = np.empty_like(q)
    for k in range(q.size):
        e = np.zeros_like(q)
        e[k] = 1e-6
        num[k] = (sim.constraint_at(q + e, X0, R0)[0] - sim.constraint_at(q - e, X0, R0)[0]) / 2e-6
    np.testing.assert_allclose(g, num, atol=1e-6)


def test_bunny_on_plane_never_interpenetrates():
    """The shipped low-poly bunny (triangles, MeshDistance) dropped on a plane: exact > 0."""
    import os

    path = os.path.join(os.path.dirname(__file__), "..", "..", "..", "scenes", "data", "meshes",
                        "bunny_low.obj")
    bunny = DataMesh.load(path, kind="triangles")
    bunny = DataMesh(bunny.V * 4, bunny.triangles)
    plane = Body.from_mesh(primitives.make({"type": "plane", "size": [2, 2], "resolution": 3}),
                           name="plane", alpha=60.0, static=True)
    body = Body.from_mesh(bunny, name="bunny", alpha=60.0, position=[0, 0, 0.0],
                          rotation=rotation_matrix([np.pi / 2, 0, 0]), velocity=[0.3, 0, -2.0],
                          angular_velocity=[0, 3, 0])
    lowest = (body.mesh.V @ body.R.T + body.x)[:, 2].min()
    body.x[2] += 0.12 - lowest                         # 0.12 above the plane
    con = ContactConstraint([plane, body], beta=0.5)
    sim = Integrator([plane, body], con, G, 0.005)
    dists, contact = [], 0
    for _ in range(25):
        st = sim.step()
        contact += st.iterations > 0
        assert st.min_c > 0
        dists.append(con.min_exact_distance(*sim.current()))
    assert contact > 5                                 # it did hit the plane
    assert min(dists) > 0
