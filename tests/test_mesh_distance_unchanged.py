"""The whole-mesh kernels' speed work (issue 17, part 4) left every result as it was.

``tests/data/whole_mesh_before_issue17.npz`` holds inputs and outputs of :class:`MeshDistance`
written by the code before that work (commit 336ba3f; see ``tests/data/README.md``):

* ``bowl_ico``: the Table 3 bowl (736 edges) and icosphere (120 edges), alpha 50;
* ``ring_toss_near``: the 1,469 ring-toss points within 0.45 of the trefoil (100 edges, resting
  on its peg), alpha 20;
* ``slide_sphere``: the slide (615 edges) and the UV sphere (960 triangles), alpha 100;
* ``mixed``: points, edges and triangles (``conftest.make_mixed``) against an octahedron, with
  attenuation (alpha_U 60), ``gradient="exact"``, ``tol=1e-9``, and the brute-force reference;

at beta 0 and 0.5, tol 0 and 1e-6, the metric and the exact gradient, at the Table 3 placement
and a rotated, shifted one. Checked: ``d_hat`` (value), the vertex gradients, the couple of
:meth:`MeshDistance.with_couple`, the per-primitive distances and gradients, and the exact
distance, each to 1e-12 relative (the couple, which nearly cancels on the symmetric bowl, to
1e-12 of the gradients' scale); for the approximations that depend on the tree's shape
(beta > 0, tol > 0) the exact distance only (see ``_check``). The geometry is stored, not
regenerated, so that a change of the generators does not move the reference.
"""

from pathlib import Path

import numpy as np
import pytest

from smoothdist import DataMesh, MeshDistance

DATA = Path(__file__).resolve().parent / "data" / "whole_mesh_before_issue17.npz"
REL = 1e-12


@pytest.fixture(scope="module")
def ref():
    with np.load(DATA) as z:
        return {k: z[k] for k in z.files}


def _variants(ref, name):
    """``{(beta, tol, gradient, pose): prefix}`` of one case."""
    out = {}
    for k in ref:
        parts = k.split("/")
        if parts[0] == name and len(parts) == 6 and parts[-1] == "d":
            beta, tol, grad, pose = float(parts[1][1:]), float(parts[2][3:]), parts[3], parts[4]
            out[(beta, tol, grad, pose)] = "/".join(parts[:5])
    return out


def _close(a, b, scale=None):
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    s = np.abs(b).max() if scale is None else scale
    assert np.abs(a - b).max() <= REL * s, (np.abs(a - b).max(), s)


def _check(md, R, t, ref, key, primitives=True, approximate=False):
    """``approximate``: Barnes-Hut (beta > 0) or tol > 0, whose values depend on the tree's
    shape; since the tree splits by the surface area heuristic (2026-11-25) they differ from
    the reference (by up to 8 % for one query primitive's gradient), so only the exact
    distance is compared then (the approximations are checked against beta 0 and brute force
    in ``tests/test_whole_mesh.py``: bounds with and without Barnes-Hut, tol)."""
    d, G = md(R, t)
    dc, Gc, C = md.with_couple(R, t)
    assert dc == d and np.array_equal(Gc, G)
    _close(md.exact(R, t)[0], ref[key + "/exact"][0])
    if approximate:
        return
    _close(d, ref[key + "/d"][0])
    _close(G, ref[key + "/G"])
    _close(C, ref[key + "/C"], scale=max(np.abs(ref[key + "/C"]).max(),
                                         np.abs(ref[key + "/G"]).max()))
    if primitives and key + "/dj" in ref:
        dj, gj = md.primitive_distances(R, t)
        _close(dj, ref[key + "/dj"])
        _close(gj, ref[key + "/gj"])


@pytest.mark.parametrize("name", ["bowl_ico", "ring_toss_near", "slide_sphere"])
def test_table3_cases_unchanged(ref, name):
    Vd = ref[f"{name}/Vd"]
    data = (Vd, ref[f"{name}/Fd"]) if f"{name}/Fd" in ref else Vd
    query = (ref[f"{name}/Vq"], ref[f"{name}/Fq"])
    alpha, alpha_q = ref[f"{name}/alpha"]
    t0 = ref[f"{name}/t"]
    variants = _variants(ref, name)
    assert variants
    for (beta, tol, grad, pose), key in sorted(variants.items()):
        md = MeshDistance(data, query, alpha=alpha, alpha_q=alpha_q, beta=beta, tol=tol,
                          gradient=grad)
        if pose == "pose0":
            R, t = None, t0
        else:
            R, t = ref[f"{name}/R1"], t0 + [0.01, 0.03, -0.02]
        _check(md, R, t, ref, key, approximate=beta > 0 or tol > 0)


def test_mixed_data_with_attenuation_unchanged(ref):
    mesh = DataMesh(ref["mixed/V"], triangles=ref["mixed/T"], edges=ref["mixed/E"],
                    points=ref["mixed/P"],
                    repair=False)
    assert (mesh.points.size, len(mesh.edges), len(mesh.triangles)) == (
        ref["mixed/P"].size, len(ref["mixed/E"]), len(ref["mixed/T"]))
    R = ref["mixed/R"]
    for beta in (0.0, 0.5):
        md = MeshDistance(mesh, (ref["mixed/oct_V"], ref["mixed/oct_F"]), alpha=30.0,
                          alpha_q=20.0, beta=beta, alpha_u=60.0, gradient="exact", tol=1e-9)
        for k in (0, 1):
            key = f"mixed/b{beta}/pose{k}"
            t = ref[key + "/t"]
            _check(md, R, t, ref, key, approximate=True)        # tol 1e-9
            d, G = md(R, t, method="brute")
            _close(d, ref[key + "/brute_d"][0])
            _close(G, ref[key + "/brute_G"])
