"""Recompute the outputs stored in ``whole_mesh_before_issue17.npz`` with today's code.

The inputs (geometry, poses, settings) stay as stored. Run from the repository root::

    python tests/data/make_whole_mesh_reference.py            # report what would change
    python tests/data/make_whole_mesh_reference.py --write    # and write the file

The report lists, per case and setting, the query primitives whose smooth distance moved by
more than 1e-12 relative, and whether each has a *tied* closest pair with some data primitive
(several candidate pairs at the same distance: parallel features, :func:`smoothdist.
closest_pair.tied_pair`). Issue 37 changed only those; a moved primitive without a tie means the
change is something else, and the script refuses to write.
"""

import sys
from pathlib import Path

import numba
import numpy as np

from smoothdist import DataMesh, MeshDistance
from smoothdist._kernels.closest_pair import distinct_ties

HERE = Path(__file__).resolve().parent
FILE = HERE / "whole_mesh_before_issue17.npz"


@numba.njit(cache=False)
def _tied_rows(kq, Qp, kd, Dp):
    """For each query primitive (rows of ``Qp``, (m, 9)), whether some data primitive (rows of
    ``Dp``) has two or more distinct tied candidate pairs with it."""
    out = np.zeros(Qp.shape[0], dtype=np.bool_)
    for j in range(Qp.shape[0]):
        for i in range(Dp.shape[0]):
            if distinct_ties(kq, Qp[j], kd, Dp[i]) > 1:
                out[j] = True
                break
    return out


def _flat(V, F):
    F = np.asarray(F)
    if F.shape[1] == 2:
        F = np.concatenate([F, F[:, 1:]], axis=1)
    return np.ascontiguousarray(V[F].reshape(len(F), 9)), (1 if F[0, 1] == F[0, 2] else 2)


def _ties(md_data, Vq, Fq, R, t):
    X = Vq @ (np.eye(3) if R is None else np.asarray(R)).T + t
    Qp, kq = _flat(X, Fq)
    Vd, Fd = md_data
    if Fd is None:
        return np.zeros(len(Qp), dtype=bool)
    Dp, kd = _flat(Vd, Fd)
    return _tied_rows(kq, Qp, kd, Dp)


def main(write):
    with np.load(FILE) as z:
        ref = {k: z[k] for k in z.files}
    new = dict(ref)
    bad = 0
    for name in ("bowl_ico", "ring_toss_near", "slide_sphere"):
        Vd = ref[f"{name}/Vd"]
        Fd = ref.get(f"{name}/Fd")
        data = (Vd, Fd) if Fd is not None else Vd
        Vq, Fq = ref[f"{name}/Vq"], ref[f"{name}/Fq"]
        alpha, alpha_q = ref[f"{name}/alpha"]
        t0 = ref[f"{name}/t"]
        for k in sorted(ref):
            parts = k.split("/")
            if not (parts[0] == name and len(parts) == 6 and parts[-1] == "d"):
                continue
            key = "/".join(parts[:5])
            beta, tol, grad, pose = float(parts[1][1:]), float(parts[2][3:]), parts[3], parts[4]
            md = MeshDistance(data, (Vq, Fq), alpha=alpha, alpha_q=alpha_q, beta=beta, tol=tol,
                              gradient=grad)
            R, t = (None, t0) if pose == "pose0" else (ref[f"{name}/R1"], t0 + [0.01, 0.03, -0.02])
            d, G = md(R, t)
            _, _, C = md.with_couple(R, t)
            new[key + "/d"] = np.array([d])
            new[key + "/G"] = G
            new[key + "/C"] = C
            new[key + "/exact"] = np.array([md.exact(R, t)[0]])
            if key + "/dj" in ref:
                dj, gj = md.primitive_distances(R, t)
                new[key + "/dj"] = dj
                new[key + "/gj"] = gj
                if beta == 0 and tol == 0:
                    moved = np.abs(dj - ref[key + "/dj"]) > 1e-12 * np.abs(ref[key + "/dj"]).max()
                    tied = _ties((Vd, Fd), Vq, Fq, R, t)
                    lone = moved & ~tied
                    bad += int(lone.sum())
                    print(f"{key}: {moved.sum()} of {len(dj)} query primitives moved "
                          f"(max {np.abs(dj - ref[key + '/dj']).max():.2e}), "
                          f"{tied.sum()} have a tied pair, {lone.sum()} moved without one")
    mesh = DataMesh(ref["mixed/V"], triangles=ref["mixed/T"], edges=ref["mixed/E"],
                    points=ref["mixed/P"], repair=False)
    R = ref["mixed/R"]
    for beta in (0.0, 0.5):
        md = MeshDistance(mesh, (ref["mixed/oct_V"], ref["mixed/oct_F"]), alpha=30.0,
                          alpha_q=20.0, beta=beta, alpha_u=60.0, gradient="exact", tol=1e-9)
        for k in (0, 1):
            key = f"mixed/b{beta}/pose{k}"
            t = ref[key + "/t"]
            d, G = md(R, t)
            _, _, C = md.with_couple(R, t)
            new[key + "/d"] = np.array([d])
            new[key + "/G"] = G
            new[key + "/C"] = C
            new[key + "/exact"] = np.array([md.exact(R, t)[0]])
            if key + "/dj" in ref:
                new[key + "/dj"], new[key + "/gj"] = md.primitive_distances(R, t)
            bd, bG = md(R, t, method="brute")
            new[key + "/brute_d"] = np.array([bd])
            new[key + "/brute_G"] = bG
            print(f"{key}: d {d:.15g} (stored {ref[key + '/d'][0]:.15g}), brute "
                  f"{bd:.15g} (stored {ref[key + '/brute_d'][0]:.15g})")
    if bad:
        sys.exit(f"{bad} query primitives moved without a tied pair: not written")
    if write:
        np.savez_compressed(FILE, **new)
        print("written", FILE)


if __name__ == "__main__":
    main("--write" in sys.argv[1:])
