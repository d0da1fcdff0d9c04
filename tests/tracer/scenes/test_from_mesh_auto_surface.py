"""``alpha="auto"`` for edges and triangles picks alpha, alpha_U and the offset together
(issue 35; :meth:`smoothdist.SmoothDistanceField.auto_surface`).

* the choice against its definition, computed here from the edges in numpy: ``C = min(0.75 x
  mean edge length, 0.08 x diagonal)``, ``alpha = 6 / C`` (``14 / C`` where ``6 / C`` is over
  16 / mean edge length; wireframes ``30 / C`` at ``C`` = 0.1 edge lengths),
  ``alpha_U = alpha``; point clouds and explicit values keep what they were (``auto_alpha``,
  20 x alpha, offset 0);
* the target, on small renders: the 95th percentile of the angle between the rendered normals
  and the true shape's (:mod:`tracer.rendering.ripple`) is at most ``max(6 degrees, 1.5 x`` the
  exact distance's offset surface at the same mean offset``)`` for a trimesh icosphere(2) as
  triangles and a 64-edge circle as edges, where the zero set of the old defaults misses it,
  and for a box of 12 triangles and a cube's 12 edges, where the first rule (``6 / C``
  everywhere) missed it too;
* scene files: ``"alpha": "auto"`` gets the same choice, a numeric alpha (the authors' files)
  renders as before.
"""

import json

import numpy as np
import pytest

import tracer
from smoothdist import DataMesh, SmoothDistanceField
from tracer.rendering import ripple as rp
from tracer.scenes.scene import load_scene

TARGET_DEG, TARGET_RATIO = 6.0, 1.5
SIZE = 96


def icosphere2():
    trimesh = pytest.importorskip("trimesh")
    m = trimesh.creation.icosphere(2)
    return DataMesh(np.asarray(m.vertices, float), np.asarray(m.faces)), m


def circle(n=64):
    s = 2 * np.pi * np.arange(n) / n
    V = np.c_[np.cos(s), np.sin(s), np.zeros(n)]
    return DataMesh(V, np.c_[np.arange(n), (np.arange(n) + 1) % n])


def expected(V, E, tube=False):
    """``(alpha, alpha_u, offset)`` of the rule, from the unique edges ``E`` (``tube``: the
    data has edges)."""
    h = np.mean(np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1))
    diag = np.linalg.norm(V.max(axis=0) - V.min(axis=0))
    c = min(0.75 * h, 0.08 * diag)
    if tube:
        c = max(c, 0.01 * diag)
    a = 6.0 / c if 6.0 / c * h <= 16.0 else 14.0 / c
    return a, a, c


def test_the_choice_follows_its_definition():
    mesh, m = icosphere2()
    got = SmoothDistanceField(mesh).auto_surface()
    np.testing.assert_allclose(got, expected(m.vertices, m.edges_unique), rtol=1e-12)
    c = circle()
    np.testing.assert_allclose(SmoothDistanceField(c).auto_surface(),
                               expected(c.V, c.edges, tube=True), rtol=1e-12)
    # a finely sampled curve: the tube keeps 1 % of the diagonal
    fine = circle(2000)
    a, au, off = SmoothDistanceField(fine).auto_surface()
    assert off == pytest.approx(0.01 * 2 * np.sqrt(2)) and 0.75 * 2 * np.pi / 2000 < off / 4
    # a box of 12 triangles: the mean edge (1.7) is capped at 8 % of the diagonal
    V = np.array([[x, y, z] for x in (-1, 1) for y in (-0.75, 0.75) for z in (-0.5, 0.5)])
    trimesh = pytest.importorskip("trimesh")
    box = trimesh.creation.box(extents=(2.0, 1.5, 1.0))
    a, au, off = SmoothDistanceField(DataMesh(np.asarray(box.vertices), box.faces)).auto_surface()
    assert off == pytest.approx(0.08 * np.linalg.norm(V.max(0) - V.min(0)))
    # ... so 6 / C would be 47 / mean edge: its few large facets get 14 / C
    assert a == pytest.approx(14.0 / off) and au == a
    np.testing.assert_allclose((a, au, off), expected(box.vertices, box.edges_unique),
                               rtol=1e-12)


def test_points_and_explicit_values_keep_the_old_choice():
    rng = np.random.default_rng(4)
    P = rng.normal(size=(400, 3))
    fld = SmoothDistanceField(P)
    a = fld.auto_alpha()
    assert fld.auto_surface() == (a, fld.auto_alpha_u(a), 0.0)
    mesh, _ = icosphere2()
    sc = tracer.mesh_scene(mesh, size=(8, 8), alpha=30.0)          # alpha given
    o = sc.objects[0]
    assert (o.alpha, o.alpha_u, o.smooth_offset) == (30.0, 600.0, 0.0)
    sc = tracer.mesh_scene(mesh, size=(8, 8), offset=0.0)          # offset given
    o = sc.objects[0]
    f = SmoothDistanceField(mesh)
    assert (o.alpha, o.alpha_u, o.smooth_offset) == (f.auto_alpha(), 20 * f.auto_alpha(), 0.0)
    sc = tracer.mesh_scene(mesh, size=(8, 8), alpha_u="off")       # alpha_u given
    assert sc.objects[0].smooth_offset == 0.0
    sc = tracer.mesh_scene(mesh, size=(8, 8), mode="exact")        # exact mode: 1/alpha
    assert sc.objects[0].offset == pytest.approx(1.0 / f.auto_alpha())
    sc = tracer.mesh_scene(mesh, size=(8, 8))                      # all auto
    o = sc.objects[0]
    assert (o.alpha, o.alpha_u, o.smooth_offset) == pytest.approx(f.auto_surface())


def _p95_pair(mesh, shape, kind, **kw):
    common = dict(kind=kind, size=(SIZE, SIZE), shading="normals", up="z")
    res = tracer.render_mesh(mesh, view="iso", **common, **kw)
    smooth = rp.ripple(res, shape)["p95"]
    r = rp.mean_offset(res)
    cam = (res.scene.camera_origin, res.scene.camera_dest, res.scene.camera_up)
    ex = tracer.render_mesh(mesh, mode="exact", offset=r, camera=cam, eps=res.scene.eps,
                            alpha=res.scene.objects[0].alpha, **common)
    return smooth, rp.ripple(ex, shape)["p95"], res


def cube_wire():
    V = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    E = np.array([(i, j) for i in range(8) for j in range(i + 1, 8)
                  if np.sum(V[i] != V[j]) == 1])
    return DataMesh(V, E)


def box12():
    trimesh = pytest.importorskip("trimesh")
    b = trimesh.creation.box(extents=(2.0, 1.5, 1.0))
    return DataMesh(np.asarray(b.vertices, float), np.asarray(b.faces))


@pytest.mark.slow
@pytest.mark.parametrize("case", ["ico2", "circle64"])
def test_the_auto_surface_meets_the_ripple_target(case):
    if case == "ico2":
        mesh, kind, shape = icosphere2()[0], "triangles", rp.Sphere(1.0)
    else:
        mesh, kind, shape = circle(), "edges", rp.Circle(1.0)
    smooth, exact, res = _p95_pair(mesh, shape, kind)
    assert res.scene.objects[0].smooth_offset > 0
    assert res.hit.sum() > 1000
    assert smooth <= max(TARGET_DEG, TARGET_RATIO * exact), (smooth, exact)
    # the old defaults (the zero set) miss it: the check can fail
    old, old_exact, _ = _p95_pair(mesh, shape, kind, offset=0.0)
    assert old > max(TARGET_DEG, TARGET_RATIO * old_exact), (old, old_exact)


@pytest.mark.slow
@pytest.mark.parametrize("case", ["box", "cube_wire"])
def test_large_facets_and_wires_meet_the_ripple_target(case):
    """A box of 12 triangles (ridges along the face diagonals) and a cube's 12 edges (bulging
    joints): both missed the target at ``alpha = 6 / C``; the exact renders are exact (0
    degrees), so the target is 6 degrees."""
    if case == "box":
        mesh, kind, shape = box12(), "triangles", rp.Box((1.0, 0.75, 0.5))
    else:
        mesh = cube_wire()
        kind, shape = "edges", rp.Segments(mesh.V, mesh.edges)
    smooth, exact, res = _p95_pair(mesh, shape, kind)
    assert res.hit.sum() > 500
    assert smooth <= max(TARGET_DEG, TARGET_RATIO * exact), (smooth, exact)
    # the first rule, alpha = 6 / C at the same offset, misses it: the check can fail
    o = res.scene.objects[0]
    old, old_exact, _ = _p95_pair(mesh, shape, kind, alpha=6.0 / o.smooth_offset,
                                  alpha_u="off", offset=o.smooth_offset)
    assert old > max(TARGET_DEG, TARGET_RATIO * old_exact), (old, old_exact)


def test_scene_files_auto_and_numeric(tmp_path):
    mesh, m = icosphere2()
    obj = tmp_path / "ico.obj"
    m.export(obj)
    cam = {"origin": [0, 0, 5], "dest": [0, 0, 0], "up": [0, 1, 0]}

    def load(alpha, **extra):
        path = tmp_path / "s.json"
        path.write_text(json.dumps({"camera": cam, "objects": [
            {"path": "ico.obj", "alpha": alpha, "bvh_type": "faces", **extra}]}))
        return load_scene(str(path)).objects[0]

    o = load("auto")
    want = expected(np.asarray(m.vertices), np.asarray(m.edges_unique))
    assert (o.alpha, o.alpha_u, o.smooth_offset) == pytest.approx(want)
    o = load(40.0, max_alpha=80.0)
    assert (o.alpha, o.alpha_u, o.smooth_offset, o.offset) == (40.0, 80.0, 0.0, 1.0 / 40.0)
    o = load(40.0)
    assert (o.alpha, o.alpha_u, o.smooth_offset) == (40.0, 800.0, 0.0)
    o = load("auto", offset=0.0)
    assert o.smooth_offset == 0.0 and o.alpha_u == 20.0 * o.alpha


def test_a_wire_net_stays_a_net():
    """Edges whose vertices join more than 2.5 of them on average (a surface's wireframe)
    are drawn as wires of radius 0.1 mean edge lengths (0.75 closed the README's torus.obj
    wireframe into a ribbed surface); curves (2 per vertex) keep the tube rule."""
    trimesh = pytest.importorskip("trimesh")
    m = trimesh.creation.icosphere(1)
    E = np.asarray(m.edges_unique)
    net = SmoothDistanceField(DataMesh(np.asarray(m.vertices, float), E))
    assert net.is_wire_net() and not SmoothDistanceField(circle()).is_wire_net()
    h = np.mean(np.linalg.norm(m.vertices[E[:, 0]] - m.vertices[E[:, 1]], axis=1))
    np.testing.assert_allclose(net.auto_surface(), (300.0 / h, 300.0 / h, 0.1 * h), rtol=1e-12)
    # holes: a flat triangulated grid's wireframe, seen face on, is mostly background
    # inside its outline (a closed sheet: none)
    n = 6
    g = np.linspace(0.0, 1.0, n)
    V = np.c_[np.repeat(g, n), np.tile(g, n), np.zeros(n * n)]
    k = np.arange(n * n).reshape(n, n)
    T = np.r_[np.c_[k[:-1, :-1].ravel(), k[1:, :-1].ravel(), k[1:, 1:].ravel()],
              np.c_[k[:-1, :-1].ravel(), k[1:, 1:].ravel(), k[:-1, 1:].ravel()]]
    grid = trimesh.Trimesh(V, T, process=False)
    wires = DataMesh(V, np.asarray(grid.edges_unique))
    assert SmoothDistanceField(wires).is_wire_net()
    cam = ([0.5, 0.5, 3.0], [0.5, 0.5, 0.0], [0.0, 1.0, 0.0])
    res = tracer.render_mesh(wires, size=(64, 64), shading="normals", camera=cam)
    rows, cols = np.nonzero(res.hit)
    box = res.hit[rows.min():rows.max() + 1, cols.min():cols.max() + 1]
    assert (~box).mean() > 0.15, (~box).mean()
    hg = SmoothDistanceField(wires).mean_edge_length()
    closed = tracer.render_mesh(wires, size=(64, 64), shading="normals", camera=cam,
                                offset=0.75 * hg, alpha=8.0 / hg, alpha_u="off")
    rows, cols = np.nonzero(closed.hit)
    box = closed.hit[rows.min():rows.max() + 1, cols.min():cols.max() + 1]
    assert (~box).mean() < 0.05, (~box).mean()


def helix(turns=3, per_turn=48):
    s = np.linspace(0.0, 2 * np.pi * turns, turns * per_turn + 1)
    V = np.c_[np.cos(s), np.sin(s), 0.8 * s / (2 * np.pi)]
    n = len(V)
    return DataMesh(V, np.c_[np.arange(n - 1), np.arange(1, n)])


def test_tubes_thinner_than_half_a_pixel_give_a_warning(tmp_path, capsys):
    """Issue 35 item 5: ``--alpha 500 --kind edges`` on a helix drew a tube thinner than a
    pixel without a word. The warning gives an alpha that shows the tube, and at that alpha
    (and at "auto") there is none."""
    import warnings

    from tracer.errors import ThinFeatureWarning

    mesh = helix()
    with pytest.warns(ThinFeatureWarning, match=r"144 edges .* thinner than half a pixel") \
            as rec:
        tracer.mesh_scene(mesh, alpha=500.0, size=(512, 512), view="iso")
    suggested = float(str(rec[0].message).split("; alpha ")[1].split(" or lower")[0])
    assert suggested < 500.0
    with warnings.catch_warnings():
        warnings.simplefilter("error", ThinFeatureWarning)
        tracer.mesh_scene(mesh, alpha=suggested, size=(512, 512), view="iso")
        tracer.mesh_scene(mesh, size=(512, 512), view="iso")
        # the tube is visible once the probes half a pixel out are inside the surface
        sc = tracer.mesh_scene(mesh, alpha=suggested, size=(512, 512), view="iso")
    o = sc.objects[0]
    half = 0.5 * np.linalg.norm(sc.camera_dest - sc.camera_origin) / 512
    q, _ = o.field._offset_probes(half, count=128)
    dh = o.field.smooth_distance(q, alpha=o.alpha, alpha_u=o.alpha_u, beta=0.5).distance
    assert np.median(dh) <= 0.0
    # on the command line: one warning line, and the render goes on
    obj = tmp_path / "helix.obj"
    obj.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in mesh.V)
                   + "".join(f"l {a + 1} {b + 1}\n" for a, b in mesh.edges))
    from tracer.cli import main

    assert main(["render", str(obj), "--alpha", "500", "--size", "96", "96", "-q",
                 "-o", str(tmp_path / "h.png"), "--shading", "normals"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("warning: the 144 edges are drawn as tubes")
    assert (tmp_path / "h.png").exists()
