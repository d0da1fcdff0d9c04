"""The fidelity measure (tracer/checks/fidelity.py, issue 46 item 1), checked where its
answer is known without it: an exact render against itself, and a sphere's silhouette against
the circle its offset gives.
"""
import numpy as np
import pytest

import tracer
from tracer.checks.fidelity import THIN_OFFSET, fidelity

trimesh = pytest.importorskip("trimesh")

SIZE = (64, 64)


def test_the_mesh_itself_scores_perfectly():
    """An exact render at the reference's own offset: the same silhouette (IoU 1) and, at its
    own mean offset, the same surface (angles of a few tenths of a degree from the offset
    differing by the hit tolerance), no streaks."""
    m = trimesh.creation.icosphere(subdivisions=3)
    L = float(np.linalg.norm(np.ptp(m.vertices, axis=0)))
    res = tracer.render_mesh(m, size=SIZE, mode="exact", offset=THIN_OFFSET * L,
                             progress=None)
    f = fidelity(res)
    assert f["iou"] == 1.0
    assert f["p95_deg"] < 1.0
    assert f["streak_share"] == 0.0
    assert f["compared"] > 0.5 * res.hit.sum()


def test_a_spheres_iou_is_that_of_its_circles():
    """A fine sphere of radius 1 drawn at mean offset c: silhouettes are discs of radius
    about 1 + c and 1 + 0.0025 L seen from the same eye, so IoU ~ ((1 + t) / (1 + c))^2
    (perspective and pixels: within 0.04). At offset 0.1, far enough out for the IoU to
    fall well below 1."""
    m = trimesh.creation.icosphere(subdivisions=4)
    res = tracer.render_mesh(m, size=SIZE, progress=None, shading="normals", offset=0.1,
                             alpha=200.0, alpha_u="off")
    f = fidelity(res)
    t = f["thin_offset"]
    assert f["offset"] > 0.09 and f["iou"] < 0.9
    assert f["iou"] == pytest.approx(((1 + t) / (1 + f["offset"])) ** 2, abs=0.04)
    assert f["p95_deg"] < 10.0


def test_point_clouds_and_curves_have_their_own_reference():
    rng = np.random.default_rng(0)
    P = rng.normal(size=(800, 3))
    P /= np.linalg.norm(P, axis=1, keepdims=True)
    res = tracer.render_mesh(P, size=SIZE, progress=None, shading="normals")
    f = fidelity(res)
    assert f["thin_offset"] == pytest.approx(res.scene.objects[0].field.point_spacing())
    assert 0.3 < f["iou"] <= 1.0
    s = np.linspace(0, 4 * np.pi, 80)
    V = np.stack([np.cos(s), np.sin(s), 0.2 * s], 1)
    E = np.stack([np.arange(79), np.arange(1, 80)], 1)
    res = tracer.render_mesh(V, E, size=SIZE, progress=None, shading="normals")
    f = fidelity(res)
    assert f["thin_offset"] == f["offset"]        # a tube of the render's own radius
    assert f["iou"] > 0.8


@pytest.mark.parametrize("name", ["annulus", "helix_strip", "pv_text", "sphere_with_holes",
                                  "cone"])
def test_the_defaults_meet_the_targets_on_a_subset(name):
    """Issue 46's three targets on shapes of benchmarks/bench_fidelity.py's corpus that the
    rule before the thin shell missed (a washer-like annulus, a thin strip, text, a sphere with
    holes fattened into cushions and tubes; a coarse cone with streaks), at the benchmark's
    128²: silhouette IoU >= 0.9, p95 normal angle <= 10 degrees, streaks <= 0.1 %. The figures
    have margins of a few pixels (benchmarks/data/fidelity.json), so another CPU's rounding
    cannot cross them. The same check with the old rule's parameters fails (IoU)."""
    pytest.importorskip("pyvista")
    from benchmarks.bench_fidelity import TARGETS, corpus

    shape = corpus()[name]
    res = tracer.render_mesh(shape, size=(128, 128), progress=None)
    f = fidelity(res)
    assert f["iou"] >= TARGETS["iou"], f
    assert f["p95_deg"] <= TARGETS["p95_deg"], f
    assert f["streak_share"] <= TARGETS["streak_share"], f
    fld = res.scene.objects[0].field
    c = min(0.75 * fld.mean_edge_length(), 0.08 * fld.diagonal)
    old = tracer.render_mesh(shape, size=(128, 128), progress=None, offset=c, alpha=6.0 / c,
                             alpha_u="off")
    assert fidelity(old)["iou"] < TARGETS["iou"]


def test_flat_faces_have_no_seams_with_the_default_weights():
    """Issue 62: pyvista's dodecahedron (each pentagon three coplanar triangles) at 256², all
    defaults: no flat pixel turns more than 1 degree from its face's plane or stands out of
    its neighbourhood (the automatic surface takes the junction weights). The control, the
    paper's weights, shows the dotted seams the measure is there to find (3.25 % turned, up to
    5.2 degrees, in benchmarks/data/fidelity_paper_weights.json): more than 0.5 %."""
    pv = pytest.importorskip("pyvista")
    from tracer.checks.fidelity import flat_seams

    solid = pv.PlatonicSolid("dodecahedron").triangulate()
    res = tracer.render_mesh(solid, size=(256, 256), progress=None)
    assert res.scene.march.weights == "inclusion-exclusion"
    s = flat_seams(res)
    assert s["flat"] > 0.3 * res.hit.sum()
    assert s["turned_share"] <= 0.005 and s["max_deg"] <= 5.0 and s["off_share"] <= 0.0005
    paper = flat_seams(tracer.render_mesh(solid, size=(256, 256), progress=None,
                                          weights="paper"))
    assert paper["turned_share"] > 0.005


def test_plane_ids_group_coplanar_triangles():
    """A box's 12 triangles lie on 6 planes, two triangles each, whatever the winding; a
    degenerate triangle gets a plane of its own."""
    from tracer.checks.fidelity import plane_ids

    box = trimesh.creation.box()
    ids, normals = plane_ids(box.vertices, box.faces)
    assert len(np.unique(ids)) == 6 and np.all(np.bincount(ids) == 2)
    F = np.concatenate([box.faces, box.faces[:1, ::-1], [[0, 0, 1]]])
    ids2, normals2 = plane_ids(box.vertices, F)
    assert ids2[12] == ids2[0] and np.all(normals2[-1] == 0) and np.sum(ids2 == ids2[-1]) == 1
