"""Regenerate the meshes of the Table 3 simulations (``meshes/*.obj``), deterministically.

    python scenes/simulations/table3/make_meshes.py             # rewrite meshes/
    python scenes/simulations/table3/make_meshes.py -o DIR      # write them elsewhere
    python scenes/simulations/table3/make_meshes.py --check     # compare with meshes/ (exit 1)

Every file comes from :mod:`tracer.sim.primitives` (the geometry the mesh-distance benchmark
uses) or from a mesh shipped in ``scenes/data``; ``meshes/README.md`` says which and how. The
files are plain OBJ: ``v`` records, ``f`` records for triangles, ``l`` records for edges (one
per edge), nothing else for points, coordinates printed with 9 significant digits, so the same
code gives the same bytes. The LiDAR terrain is not a file: it is built when a simulation is
loaded (the ``lidar_terrain`` primitive).
"""

import argparse
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", "..", ".."))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from smoothdist import DataMesh  # noqa: E402
from tracer.sim import primitives as P  # noqa: E402

DATA = os.path.join(ROOT, "scenes", "data")
#: the octopus' triangle count in the paper's Table 3
OCTOPUS_TRIANGLES = 4432


def write_obj(path, V, E=None, F=None, header=()):
    """An OBJ file of vertices ``V``, edges ``E`` and triangles ``F``. Edges are 2-vertex ``f``
    records, the only edges the authors' reader takes (``l`` lines are skipped by it); ours
    reads both."""
    lines = [f"# {h}" for h in header]
    lines += ["v " + " ".join(f"{x:.9g}" for x in v) for v in np.asarray(V, float)]
    if E is not None:
        lines += [f"f {a + 1} {b + 1}" for a, b in np.asarray(E)]
    if F is not None:
        lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in np.asarray(F)]
    with open(path, "w", newline="\n") as fh:
        fh.write("\n".join(lines) + "\n")


def bisect_longest_edges(V, F, count):
    """Split the longest edge of a closed triangle mesh ``count`` times (its midpoint becomes a
    vertex and each of the two triangles on it becomes two): ``2 * count`` more triangles, the
    surface unchanged. Ties go to the edge with the smaller vertex indices."""
    V, F = [list(map(float, v)) for v in V], [list(map(int, f)) for f in F]
    for _ in range(count):
        Va = np.asarray(V)
        Fa = np.asarray(F)
        E = np.sort(np.concatenate([Fa[:, [0, 1]], Fa[:, [1, 2]], Fa[:, [2, 0]]]), axis=1)
        E = np.unique(E, axis=0)
        L = np.linalg.norm(Va[E[:, 1]] - Va[E[:, 0]], axis=1)
        a, b = (int(x) for x in E[np.lexsort((E[:, 1], E[:, 0], -L))[0]])
        m = len(V)
        V.append(list(0.5 * (Va[a] + Va[b])))
        out = []
        for f in F:
            if a in f and b in f:     # (a, b, c) -> (m, b, c) and (a, m, c): same orientation
                out.append([m if v == a else v for v in f])
                out.append([m if v == b else v for v in f])
            else:
                out.append(f)
        F = out
    return np.asarray(V), np.asarray(F)


def octopus(target=OCTOPUS_TRIANGLES):
    """``scenes/data/meshes/octopus_low.obj`` (898 triangles) refined to ``target`` triangles:
    one Loop subdivision (3,592 triangles, smooth), then the longest edge bisected
    ``(target - 3592) / 2`` times (420 for 4,432)."""
    import trimesh.remesh

    m = DataMesh.load(os.path.join(DATA, "meshes", "octopus_low.obj"))
    V, F = trimesh.remesh.subdivide_loop(m.V, m.triangles, iterations=1)
    extra = target - len(F)
    if extra < 0 or extra % 2:
        raise ValueError(f"cannot reach {target} triangles from {len(F)} by bisection")
    return bisect_longest_edges(V, F, extra // 2)


def meshes():
    """``{file name: (V, E, F, header lines)}`` of every committed mesh."""
    out = {}
    # the bowl scenes at 4 times the benchmark's size and the ring toss at twice it: the paper's
    # alphas (20 for the spiky sphere and the ring toss) are absolute lengths, and at the
    # benchmark's size their smooth surfaces would swallow the spikes and fatten the pegs
    V, E = P.bowl_edges(radius=4.0)
    out["bowl_edges.obj"] = (V, E, None, ["the paper's wire bowl: tracer.sim.primitives."
                                          "bowl_edges(radius=4), open upwards (+y), 736 edges"])
    V, E = P.icosphere_edges(radius=1.0)
    out["ico_edges.obj"] = (V, E, None, ["tracer.sim.primitives.icosphere_edges(radius=1): "
                                         "icosphere (1 subdivision), 120 edges"])
    V, F = P.uv_sphere(radius=1.2)
    out["spikeball_sphere.obj"] = (V, None, F, ["tracer.sim.primitives.uv_sphere(radius=1.2): "
                                                "poles on y, 960 triangles"])
    V, E = P.spikes(radius=1.2, length=1.0)
    out["spikeball_spikes.obj"] = (V, E, None, ["tracer.sim.primitives.spikes(radius=1.2, "
                                                "length=1): 6 edges from the vertices of "
                                                "spikeball_sphere.obj on the axes out to 2.2"])
    V, F = P.uv_sphere()
    out["sphere.obj"] = (V, None, F, ["tracer.sim.primitives.uv_sphere(): radius 0.3, poles on "
                                      "y, 960 triangles"])
    V, E = P.slide_edges()
    out["slide_edges.obj"] = (V, E, None, ["the paper's wire slide: tracer.sim.primitives."
                                           "slide_edges(), 615 edges"])
    out["ringtoss.obj"] = (2.0 * P.ring_toss_points(), None, None,
                           ["the paper's ring toss: tracer.sim.primitives.ring_toss_points() x "
                            "2, 12,400 points (8 x 8 board at y = 0, 6 pegs along +y)"])
    V, E = P.trefoil_100(os.path.join(DATA, "curves", "trefoil.obj"))
    out["trefoil_edges.obj"] = (2.0 * V, E, None, ["tracer.sim.primitives.trefoil_100() x 2: "
                                                   "scenes/data/curves/trefoil.obj resampled "
                                                   "to 100 edges, bbox diagonal 4, lying flat "
                                                   "(thin axis y)"])
    bunny = DataMesh.load(os.path.join(DATA, "bunny.off"))
    out["bunny10.obj"] = (10.0 * bunny.V, None, bunny.triangles,
                          ["scenes/data/bunny.off (Stanford bunny, 6,966 triangles) scaled by "
                           "10 (the authors' bunny10.obj)"])
    plane = P.make({"type": "plane", "size": [8, 8], "resolution": 20, "bumps": 0.12,
                    "bump_count": 5})
    out["bumpy_plane.obj"] = (plane.V, None, plane.triangles,
                              ["tracer.sim.primitives plane: size [8, 8], resolution 20, bumps "
                               "0.12, bump_count 5: 800 triangles at z = 0 (+- 0.12), normal +z"])
    V, F = octopus()
    out["octopus_4432.obj"] = (V, None, F, [
        "scenes/data/meshes/octopus_low.obj (898 triangles) refined to the paper's 4,432: one "
        "Loop subdivision", "(trimesh.remesh.subdivide_loop, 3,592 triangles), then the longest "
        "edge bisected 420 times (make_meshes.py)"])
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("-o", "--out", default=os.path.join(HERE, "meshes"),
                    help="output folder (default: meshes/ next to this script)")
    ap.add_argument("--check", action="store_true",
                    help="write to a scratch folder and compare with --out byte for byte")
    args = ap.parse_args(argv)
    if args.check:
        import filecmp
        import tempfile

        with tempfile.TemporaryDirectory() as tmp:
            main(["-o", tmp])
            names = sorted(os.listdir(tmp))
            bad = [n for n in names if not os.path.exists(os.path.join(args.out, n))
                   or not filecmp.cmp(os.path.join(tmp, n), os.path.join(args.out, n),
                                      shallow=False)]
        for n in bad:
            print(f"differs: {n}")
        print(f"{len(names) - len(bad)} of {len(names)} files identical")
        return 1 if bad else 0
    os.makedirs(args.out, exist_ok=True)
    for name, (V, E, F, header) in meshes().items():
        header = header + ["generated by scenes/simulations/table3/make_meshes.py"]
        write_obj(os.path.join(args.out, name), V, E, F, header)
        print(f"{name}: {len(V)} vertices, {0 if E is None else len(E)} edges, "
              f"{0 if F is None else len(F)} triangles")
    return 0


if __name__ == "__main__":
    sys.exit(main())
