"""Exact torques (issue 17): the rotational derivative of the whole-mesh smooth distance.

References: central finite differences of the *same* function (the distance value at rotated
poses, same beta), an all-pairs numpy reference (tests/naive_pairs.py, no BVH) and the equal
split, which the exact torque must beat by orders of magnitude (so the tests can fail).
"""

import numpy as np
import pytest
from conftest import make_circle, make_icosphere, make_mixed

import naive_pairs
from smoothdist import DataMesh, MeshDistance
from smoothdist._kernels.box_distance import box_box_offset, box_lower_bound
from smoothdist._kernels.box_moment import box_lower_bound_moment, extreme_levers, gap_moment
from smoothdist._kernels.mesh_query import query_box
from tracer.sim import primitives
from tracer.sim.bodies import Body, rotation_matrix
from tracer.sim.constraint import ContactConstraint
from tracer.sim.integrator import Integrator

H = 1e-6


def _octahedron():
    V = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1.]]) * 0.4
    F = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5],
                  [0, 3, 5]])
    return V, F


def _polyline():
    t = np.linspace(0, 2 * np.pi, 9)[:-1]
    V = np.stack([0.5 * np.cos(t), 0.3 * np.sin(2 * t), 0.2 * t], axis=1)
    return V, np.stack([np.arange(7), np.arange(1, 8)], axis=1)


def _mixed_query():
    """Triangles, edges and points in one query mesh (scaled down)."""
    m = make_mixed()
    return DataMesh(m.V * 0.4, points=m.points, edges=m.edges, triangles=m.triangles,
                    name="mixed_query")


QUERIES = {"triangles": _octahedron(), "edges": _polyline(), "mixed": _mixed_query()}
DATA = {"triangles": make_icosphere(subdivisions=2), "edges": make_circle(n=24)}


def fd_torque(md, R, t, h=H):
    """Central differences of ``d_hat`` for world rotations of the query about ``t``."""
    num = np.empty(3)
    for a in range(3):
        e = np.zeros(3)
        e[a] = h
        num[a] = (md(rotation_matrix(e) @ R, t)[0] - md(rotation_matrix(-e) @ R, t)[0]) / (2 * h)
    return num


def poses(seed, n=3, md=None, gap=0.1):
    """``n`` random ``(R, t)``; with ``md``, ``t`` along a random direction at an exact gap
    ``gap`` (apart: in penetration the pairs' closest points are not unique)."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        R = rotation_matrix(rng.normal(size=3))
        if md is None:
            out.append((R, 1.45 * u))
            continue
        try:
            out.append((R, md.translation_at_gap(gap, -u, start=6.0 * u, R=R)))
        except ValueError:                   # through the hole of a ring: another direction
            pass
    return out


# ---------------------------------------------------------------------- whole-mesh torques
@pytest.mark.parametrize("beta", [0.0, 0.5])
@pytest.mark.parametrize("dname", list(DATA))
@pytest.mark.parametrize("qname", list(QUERIES))
def test_exact_torque_matches_finite_differences(qname, dname, beta):
    """Exact torque == central differences of the same function (beta 0 and 0.5) to 1e-7 of
    its size; the equal split is off by more than 1 % (measured 2-70 %)."""
    md = MeshDistance(DATA[dname], QUERIES[qname], alpha=20.0, alpha_q=15.0, beta=beta,
                      alpha_u=40.0, gradient="exact")
    seed = list(QUERIES).index(qname) + 10 * list(DATA).index(dname)
    for R, t in poses(seed, md=md):
        d, F, T = md.rigid_gradient(R, t)
        _, F_s, T_s = md.rigid_gradient(R, t, torques="split")
        num = fd_torque(md, R, t)
        scale = np.linalg.norm(num)
        assert scale > 1e-3                                   # a real torque
        np.testing.assert_allclose(T, num, atol=1e-7 * scale)
        assert np.linalg.norm(T_s - num) > 1e-2 * scale       # split is visibly wrong
        np.testing.assert_array_equal(F, F_s)                 # same translation gradient


def test_exact_torque_with_far_field_and_tol():
    """A far query (most nodes in the far field, all its cases) and the tol rule: still the
    derivative of the value."""
    for beta, tol in ((0.5, 0.0), (1.0, 0.0), (0.5, 1e-3)):
        md = MeshDistance(DATA["triangles"], QUERIES["mixed"], alpha=6.0, alpha_q=5.0,
                          beta=beta, tol=tol, gradient="exact")
        for R, t in poses(5, n=4):
            t = 2.2 * t
            d, F, T = md.rigid_gradient(R, t)
            num = fd_torque(md, R, t)
            np.testing.assert_allclose(T, num, atol=2e-7 * np.linalg.norm(num))


def test_metric_gradient_uses_the_same_moment():
    """With the paper's alpha-metric (not a derivative) the couple still only moves the
    application points: exact and split differ by the same couple as with gradient="exact"
    up to the weight-gradient scale, and forces agree."""
    md = MeshDistance(DATA["triangles"], QUERIES["triangles"], alpha=20.0, alpha_q=15.0,
                      beta=0.5, gradient="metric")
    R, t = poses(2)[0]
    d, G, C = md.with_couple(R, t)
    d0, G0 = md(R, t)
    assert d == d0
    np.testing.assert_array_equal(G, G0)
    assert np.all(np.isfinite(C)) and np.linalg.norm(C) > 0


@pytest.mark.parametrize("beta", [0.0, 0.5])
def test_values_and_forces_bit_identical_to_the_split_path(beta):
    for qname, q in QUERIES.items():
        for tol in (0.0, 1e-3):
            md = MeshDistance(DATA["triangles"], q, alpha=20.0, alpha_q=15.0, beta=beta,
                              alpha_u=40.0, gradient="exact", tol=tol)
            for R, t in poses(7, n=2):
                for method in ("bvh", "brute"):
                    d0, g0 = md.primitive_distances(R, t, method=method)
                    d1, g1, _ = md.primitive_moments(R, t, method=method)
                    np.testing.assert_array_equal(d0, d1)
                    np.testing.assert_array_equal(g0, g1)
                    D0, G0 = md(R, t, method=method)
                    D1, G1, _ = md.with_couple(R, t, method=method)
                    assert D0 == D1
                    np.testing.assert_array_equal(G0, G1)


@pytest.mark.parametrize("beta", [0.0, 0.5])
def test_points_exact_and_split_agree_exactly(beta):
    pts = np.random.default_rng(4).normal(size=(30, 3)) * 0.3
    for data in DATA.values():
        md = MeshDistance(data, pts, alpha=20.0, alpha_q=15.0, beta=beta, gradient="exact")
        for R, t in poses(8):
            for method in ("bvh", "brute"):
                d, g, mo = md.primitive_moments(R, t, method=method)
                assert np.all(mo == 0.0)
                _, _, C = md.with_couple(R, t, method=method)
                assert np.all(C == 0.0)
                e = md.rigid_gradient(R, t, method=method)
                s = md.rigid_gradient(R, t, torques="split", method=method)
                assert e[0] == s[0]
                np.testing.assert_array_equal(e[1], s[1])
                np.testing.assert_array_equal(e[2], s[2])
            # and the point torque is the derivative (points were always exact)
            num = fd_torque(md, R, t)
            np.testing.assert_allclose(md.rigid_gradient(R, t)[2], num,
                                       atol=1e-7 * np.linalg.norm(num))
    # the point primitives of a mixed query contribute no moment
    md = MeshDistance(DATA["triangles"], QUERIES["mixed"], alpha=20.0, alpha_q=15.0, beta=0.5)
    mo = md.primitive_moments(*poses(9)[0])[2]
    assert np.all(mo[md.query.kind == 0] == 0.0) and np.any(mo[md.query.kind > 0] != 0.0)


# ---------------------------------------------------------------------- numpy reference
def _rotate_about(V, c, w):
    return (V - c) @ rotation_matrix(w).T + c


def test_moments_match_all_pairs_numpy_reference_for_point_data():
    """Point data (weights 1): per primitive ``M_j = sum_i softmax_i (p_ij - c_j) x unit(r_ij)``
    with the closest pairs of tests/naive_pairs.py (face enumeration, no BVH), and the couple
    ``C = sum_j softmax_j M_j``."""
    rng = np.random.default_rng(12)
    P = rng.normal(size=(25, 3))
    alpha, alpha_q = 6.0, 4.0
    for Vq, Fq in (_octahedron(), _polyline()):
        R = rotation_matrix(rng.normal(size=3))
        t = np.array([0.3, 2.1, -0.4])
        md = MeshDistance(P, (Vq, Fq), alpha=alpha, alpha_q=alpha_q, beta=0.0, gradient="exact")
        d, g, mo = md.primitive_moments(R, t)
        X = Vq @ R.T + t
        kq = Fq.shape[1] - 1
        ref_d, ref_m = [], []
        for f in Fq:
            Q = np.repeat(X[f][None], P.shape[0], axis=0)
            dist, lam, _ = naive_pairs.closest_pairs(kq, Q, 0, P[:, None, :])
            p = np.einsum("na,nak->nk", lam, Q)
            u = (p - P) / dist[:, None]
            w = np.exp(-alpha * (dist - dist.min()))
            ref_d.append(dist.min() - np.log(w.sum()) / alpha)
            ref_m.append((w[:, None] * np.cross(p - X[f].mean(axis=0), u)).sum(axis=0) / w.sum())
        np.testing.assert_allclose(d, ref_d, rtol=1e-10)
        np.testing.assert_allclose(mo, np.array(ref_m), atol=1e-10)
        e = np.exp(-alpha_q * (d - d.min()))
        np.testing.assert_allclose(md.with_couple(R, t)[2], (e / e.sum()) @ np.array(ref_m),
                                   atol=1e-10)


@pytest.mark.parametrize("dname", ["triangles", "edges"])
def test_moments_match_numpy_reference_with_weights(dname):
    """Weighted data: each primitive's moment == central differences of the all-pairs numpy
    value ``d_hat_j`` (tests/naive_pairs.py) for rotations about its centroid; the weight's
    own motion (the data-side closest point following a rotating query edge) is included."""
    data = make_icosphere(subdivisions=1) if dname == "triangles" else make_circle(n=16)
    alpha, alpha_u = 8.0, 30.0
    for Vq, Fq in (_octahedron(), _polyline()):
        R = rotation_matrix([0.4, -0.8, 0.3])
        t = np.array([0.2, 1.5, 0.4])
        md = MeshDistance(data, (Vq, Fq), alpha=alpha, alpha_q=5.0, beta=0.0, alpha_u=alpha_u,
                          gradient="exact")
        d, _, mo = md.primitive_moments(R, t)
        X = Vq @ R.T + t
        for j, f in enumerate(Fq):
            c = X[f].mean(axis=0)
            num = np.empty(3)
            for a in range(3):
                e = np.zeros(3)
                e[a] = H
                vals = [naive_pairs.smooth_mesh_distance(_rotate_about(X, c, s * e), Fq, data,
                                                         alpha, 5.0, alpha_u)[1][j]
                        for s in (1, -1)]
                num[a] = (vals[0] - vals[1]) / (2 * H)
            np.testing.assert_allclose(mo[j], num, atol=2e-7 * max(1.0, np.linalg.norm(num)))


# ---------------------------------------------------------------------- far-field moments
def _branch(kq, Q, lo, hi):
    """Which case of box_lower_bound applies: 'corner', 'edge', 'axis' or 'normal'."""
    qlo, qhi = np.empty(3), np.empty(3)
    query_box(kq, Q, qlo, qhi)
    g = np.where(lo[0] - qhi > 0, lo[0] - qhi, np.where(qlo - hi[0] > 0, qlo - hi[0], 0.0))
    nsep = int((g > 0).sum())
    if nsep != 1:
        return {0: "none", 2: "edge", 3: "corner"}[nsep]
    delta = box_lower_bound(kq, Q, qlo, qhi, lo, hi, 0, np.empty(9))[0]
    return "axis" if delta == g.max() else "normal"


def _bound(kq, Q, lo, hi, which):
    qlo, qhi = np.empty(3), np.empty(3)
    query_box(kq, Q, qlo, qhi)
    if which == "offset":
        return box_box_offset(qlo, qhi, lo, hi, 0)
    return box_lower_bound(kq, Q, qlo, qhi, lo, hi, 0, np.empty(9))


def test_far_field_moments_match_finite_differences_in_every_case():
    """Every case of the box lower bound (corner, edge, axis gap, triangle normal) and the
    box-box offset: the moment about the centroid is the derivative for rotations about it."""
    rng = np.random.default_rng(3)
    lo = np.array([[0.0, 0.0, 0.0]])
    hi = np.array([[1.0, 0.6, 0.8]])
    seen = {}
    for _ in range(400):
        kq = int(rng.integers(1, 3))
        centre = rng.uniform(-1.5, 2.5, size=3)
        Qv = centre + rng.normal(size=(kq + 1, 3)) * rng.uniform(0.1, 1.2)
        Q = np.zeros(9)
        Q[:3 * (kq + 1)] = Qv.ravel()
        Q[3 * (kq + 1):] = np.tile(Qv[-1], 2 - kq)
        case = _branch(kq, Q, lo, hi)
        if case == "none":
            continue
        seen[case] = seen.get(case, 0) + 1
        c = Qv.mean(axis=0)
        qlo, qhi = np.empty(3), np.empty(3)
        query_box(kq, Q, qlo, qhi)
        L = np.empty(18)
        extreme_levers(kq, Q, *c, L)
        out = box_lower_bound_moment(kq, Q, qlo, qhi, lo, hi, 0, np.empty(9), *c, L)
        ref = box_lower_bound(kq, Q, qlo, qhi, lo, hi, 0, np.empty(9))
        assert out[:4] == ref                                      # bit for bit
        off = box_box_offset(qlo, qhi, lo, hi, 0)
        m_off = gap_moment(L, off[1], off[2], off[3])
        for which, mom in (("lower", out[4:]), ("offset", m_off)):
            num = np.empty(3)
            for a in range(3):
                e = np.zeros(3)
                e[a] = H
                v = [_bound(kq, np.r_[_rotate_about(Qv, c, s * e).ravel(),
                                      np.tile(_rotate_about(Qv, c, s * e)[-1], 2 - kq)],
                            lo, hi, which)[0] for s in (1, -1)]
                num[a] = (v[0] - v[1]) / (2 * H)
            if np.abs(num).max() > 1e3:                            # a case switch in between
                continue
            np.testing.assert_allclose(mom, num, atol=1e-7, err_msg=f"{case} {which}")
    assert all(seen.get(k, 0) >= 5 for k in ("corner", "edge", "axis", "normal")), seen


# ---------------------------------------------------------------------- the constraint
def _two_bodies(torques, factory=None):
    box = primitives.make({"type": "box", "size": [0.5, 0.3, 0.4]})
    ico = primitives.make({"type": "icosphere", "radius": 0.35, "subdivisions": 1})
    a = Body.from_mesh(ico, name="a", alpha=15.0, position=[0, 0, 0],
                       rotation=rotation_matrix([0.3, 0.1, -0.2]))
    b = Body.from_mesh(box, name="b", alpha=12.0, position=[0.55, 0.45, 0.2],
                       rotation=rotation_matrix([0.2, -0.4, 0.9]))
    con = ContactConstraint([a, b], beta=0.5, torques=torques, factory=factory)
    return Integrator([a, b], con, np.zeros(3), 0.01)


def test_constraint_rotation_gradient_exact_vs_split():
    """Both bodies move: the exact rotation gradient (data and query body) matches central
    differences of ``c``; split is off by more than 1 %."""
    q = None
    errs = {}
    for torques in ("exact", "split"):
        sim = _two_bodies(torques)
        X0, R0 = sim.current()
        q = np.r_[X0[0], [0.1, -0.2, 0.3], X0[1], [-0.3, 0.2, 0.05]]
        c, g = sim.constraint_at(q, X0, R0)
        num = np.empty_like(q)
        for k in range(q.size):
            e = np.zeros_like(q)
            e[k] = H
            num[k] = (sim.constraint_at(q + e, X0, R0)[0]
                      - sim.constraint_at(q - e, X0, R0)[0]) / (2 * H)
        rot = np.r_[3:6, 9:12]
        errs[torques] = np.linalg.norm(g[rot] - num[rot]) / np.linalg.norm(num[rot])
        np.testing.assert_allclose(g[:3], num[:3], atol=1e-7)    # translations: both exact
        np.testing.assert_allclose(g[6:9], num[6:9], atol=1e-7)
    assert errs["exact"] < 1e-7
    assert errs["split"] > 1e-2


def test_constraint_point_bodies_identical_either_way():
    cloud = primitives.make({"type": "sphere_points", "radius": 0.3, "count": 25})
    plane = primitives.make({"type": "plane", "size": [2, 2], "resolution": 3})
    out = []
    for torques in ("exact", "split"):
        bodies = [Body.from_mesh(plane, name="plane", alpha=20.0, static=True),
                  Body.from_mesh(cloud, name="c", alpha=20.0, position=[0.1, 0, 0.4],
                                 rotation=rotation_matrix([0.3, 0.2, 0.1]))]
        con = ContactConstraint(bodies, torques=torques)
        X = np.array([b.x for b in bodies])
        Rs = np.array([b.R for b in bodies])
        out.append(con.evaluate(X, Rs))
    assert out[0][0] == out[1][0]
    np.testing.assert_array_equal(out[0][1], out[1][1])
    np.testing.assert_array_equal(out[0][2], out[1][2])


def test_torques_option_is_validated_and_plumbed(tmp_path):
    from tracer.sim import run
    from tracer.sim.cli_simulate import add_arguments
    import argparse

    with pytest.raises(ValueError, match="torques"):
        _two_bodies("centroid")
    assert _two_bodies("split").constraint.torques == "split"
    assert ContactConstraint(_two_bodies("exact").bodies).torques == "exact"   # the default
    p = argparse.ArgumentParser()
    add_arguments(p)
    assert p.parse_args(["s.json", "-o", "d", "--torques", "split"]).torques == "split"
    assert p.parse_args(["s.json", "-o", "d"]).torques is None
    with pytest.raises(SystemExit):
        p.parse_args(["s.json", "-o", "d", "--torques", "centroid"])

    class Sim:                                         # what run.build reads of a Simulation
        bodies = _two_bodies("exact").bodies
        beta, constraint, gravity, dt, gap_tol, torques = 0.5, "smooth", np.zeros(3), 0.01, \
            None, "split"

    assert run.build(Sim)[0].torques == "split"
    assert run.build(Sim, torques="exact")[0].torques == "exact"


def _box_file(tmp_path, **top):
    spec = {
        "name": "box", "dt": 0.01, "steps": 8, "gravity": [0, 0, -9.81],
        "camera": {"origin": [0, -3, 1.0], "dest": [0, 0, 0.2], "up": [0, 0, 1], "width": 32,
                   "height": 24},
        "bodies": [
            {"name": "floor", "primitive": {"type": "plane", "size": [2, 2], "resolution": 2},
             "alpha": 30, "static": True},
            {"name": "box", "primitive": {"type": "box", "size": [0.5, 0.3, 0.2]}, "alpha": 30,
             "position": [0, 0, 0.35], "rotation": [0.4, 0.2, 0], "velocity": [0, 0, -2.0]},
        ],
    }
    spec.update(top)
    p = tmp_path / "box.json"
    p.write_text(__import__("json").dumps(spec))
    return p


def test_torques_key_and_cli_flag(tmp_path, capsys):
    """``"torques"`` in the file and ``--torques`` on the command line (which wins) give the
    same run; exact and split differ once the box tilts on the floor; a bad value is a
    one-line error."""
    from tracer.cli import main
    from tracer.errors import SimFileError
    from tracer.sim.simfile import load_simulation

    assert load_simulation(_box_file(tmp_path)).torques == "exact"
    assert load_simulation(_box_file(tmp_path, torques="split")).torques == "split"
    runs = {}
    for name, top, flag in (("file", {"torques": "split"}, []),
                            ("flag", {"torques": "exact"}, ["--torques", "split"]),
                            ("exact", {}, [])):
        out = tmp_path / name
        sim = _box_file(tmp_path, **top)
        assert main(["simulate", str(sim), "-o", str(out), "--no-render", "-q"] + flag) == 0
        runs[name] = np.load(out / "trajectory.npz")
    assert runs["exact"]["ipm_iterations"].sum() > 0              # it hit the floor
    np.testing.assert_array_equal(runs["file"]["rotations"], runs["flag"]["rotations"])
    assert not np.array_equal(runs["file"]["rotations"], runs["exact"]["rotations"])
    capsys.readouterr()
    bad = _box_file(tmp_path, torques="centroid")
    assert main(["simulate", str(bad), "-o", str(tmp_path / "bad"), "--no-render"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "box.json: torques must be one of exact, split" in err[0], err
    with pytest.raises(SimFileError):
        load_simulation(bad)
