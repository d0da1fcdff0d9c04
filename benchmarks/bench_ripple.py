"""Ripples: normal error of smooth renders of tessellated analytic shapes (issue 35).

For each case (an analytic shape tessellated the way users do: trimesh and pyvista shapes as
triangles, polylines and wireframes as edges, samples as points) and each setting, one
smooth render at ``--size`` (256 x 256), view ``iso``, normal shading, and one exact-distance
render from the same camera at the smooth surface's mean offset (the mean exact distance from
its hit points to the data); for both, the p50 / p95 angle between the rendered normals and
the analytic shape's normal at the point closest to each hit (:mod:`tracer.rendering.ripple`). A row
meets the target when the smooth p95 is at most ``max(6, 1.5 x the exact p95)`` degrees.

A setting is ``NAME:key=value,...`` with keys

* ``alpha``: ``auto``, a number, ``M/c`` (M divided by the offset c) or ``M/h`` (M divided by
  the spacing h: the data's mean edge length, or the points' median spacing);
* ``alpha_u``: ``auto``, ``off`` or ``Kx`` (K x alpha);
* ``offset``: ``auto``, a number (scene units) or ``Kh`` (K x h), the smooth surface
  ``d_hat = c``;
* ``cap``: a fraction F of the bbox diagonal: ``c = min(c, F x diagonal)``;
* ``weights``: ``auto``, ``paper`` or ``inclusion-exclusion`` (``render_mesh``'s ``weights``,
  issue 62).

``default`` is ``render_mesh``'s defaults (``alpha=auto,alpha_u=auto,offset=auto``: for edges
and triangles :meth:`smoothdist.SmoothDistanceField.auto_surface` picks all three, issue 35);
``today`` is the defaults before that (``alpha=auto,alpha_u=auto,offset=0``: the zero set).

Usage::

    python benchmarks/bench_ripple.py                              # today's defaults, all cases
    python benchmarks/bench_ripple.py --settings today default --out renders/ripple/auto.csv
    python benchmarks/bench_ripple.py --settings default "c1:offset=1h,alpha=4/c,alpha_u=off"
    python benchmarks/bench_ripple.py --cases ico2 circle64 --size 128

Writes ``--out`` (default ``renders/ripple/ripple.csv``) and a JSON file of the same rows next
to it (``ripple.json``), with the date and the thread count.
"""

import argparse
import csv
import datetime
import json
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run from a checkout without installing
    sys.path.insert(0, str(ROOT))

import numba  # noqa: E402

import tracer  # noqa: E402
from smoothdist import DataMesh, MeshRepairWarning, SmoothDistanceField  # noqa: E402
from tracer.rendering import ripple as rp  # noqa: E402

TARGET_DEG = 6.0
TARGET_RATIO = 1.5


# ------------------------------------------------------------------------------ the cases
def _trimesh():
    import trimesh

    return trimesh


def _polyline(P, closed):
    n = len(P)
    E = np.c_[np.arange(n - (0 if closed else 1)), (np.arange(n - (0 if closed else 1)) + 1) % n]
    return DataMesh(P, E)


def _circle(n=64, R=1.0):
    s = 2 * np.pi * np.arange(n) / n
    return _polyline(np.c_[R * np.cos(s), R * np.sin(s), np.zeros(n)], True)


def _helix(turns=3, per_turn=48, R=1.0, pitch=0.8):
    h = rp.Helix(R, pitch, turns)
    s = np.linspace(0.0, 2 * np.pi * turns, turns * per_turn + 1)
    return _polyline(h.point(s), False), h


def _cube_wire(half=1.0):
    V = np.array([[x, y, z] for x in (-half, half) for y in (-half, half) for z in (-half, half)])
    E = np.array([(i, j) for i in range(8) for j in range(i + 1, 8)
                  if np.sum(V[i] != V[j]) == 1])
    return DataMesh(V, E)


def _tri(m):
    return DataMesh(np.asarray(m.vertices, float), np.asarray(m.faces))


def _pv_tri(mesh):
    mesh = mesh.triangulate().clean()
    F = np.asarray(mesh.faces).reshape(-1, 4)[:, 1:]
    return DataMesh(np.asarray(mesh.points, float), F)


def _random_sphere(n=2000, seed=3):
    v = np.random.default_rng(seed).normal(size=(n, 3))
    return DataMesh(v / np.linalg.norm(v, axis=1, keepdims=True))


def build_cases():
    """``{name: (shape label, kind, data (DataMesh), analytic shape)}``."""
    import pyvista as pv

    tm = _trimesh()
    cases = {}

    def add(name, label, kind, data, shape):
        cases[name] = (label, kind, data, shape)

    sphere = rp.Sphere(1.0)
    add("ico2", "sphere: trimesh icosphere(2)", "triangles", _tri(tm.creation.icosphere(2)),
        sphere)
    add("ico3", "sphere: trimesh icosphere(3)", "triangles", _tri(tm.creation.icosphere(3)),
        sphere)
    add("uv_sphere", "sphere: trimesh uv_sphere()", "triangles", _tri(tm.creation.uv_sphere()),
        sphere)
    add("pv_sphere", "sphere r 0.5: pyvista Sphere()", "triangles", _pv_tri(pv.Sphere()),
        rp.Sphere(0.5))
    add("capsule", "capsule: trimesh capsule()", "triangles", _tri(tm.creation.capsule()),
        rp.Capsule((0, 0, -0.5), (0, 0, 0.5), 1.0))
    add("torus", "torus 1/0.3: trimesh torus()", "triangles", _tri(tm.creation.torus(1.0, 0.3)),
        rp.Torus(1.0, 0.3))
    add("box", "box 2x1.5x1: trimesh box()", "triangles",
        _tri(tm.creation.box(extents=(2.0, 1.5, 1.0))), rp.Box((1.0, 0.75, 0.5)))
    add("pv_box", "cube: pyvista Box(level=3)", "triangles", _pv_tri(pv.Box(level=3)),
        rp.Box((1.0, 1.0, 1.0)))
    add("superellipsoid", "x^4+y^4+z^4=1: pyvista ParametricSuperEllipsoid(n1=n2=0.5)",
        "triangles", _pv_tri(pv.ParametricSuperEllipsoid(n1=0.5, n2=0.5)), rp.RoundedCube(1.0))
    add("circle64", "circle: 64-segment polyline", "edges", _circle(), rp.Circle(1.0))
    helix, hshape = _helix()
    add("helix", "helix: 3 turns, 48 segments per turn", "edges", helix, hshape)
    ico1 = tm.creation.icosphere(1)
    add("ico1_wire", "wireframe: trimesh icosphere(1) edges", "edges",
        DataMesh(np.asarray(ico1.vertices, float), np.asarray(ico1.edges_unique)),
        rp.Segments(ico1.vertices, ico1.edges_unique))
    cube = _cube_wire()
    add("cube_wire", "wireframe: the 12 edges of a cube", "edges", cube,
        rp.Segments(cube.V, cube.edges))
    add("ico3_points", "sphere: icosphere(3) vertices", "points",
        DataMesh(np.asarray(tm.creation.icosphere(3).vertices, float)), sphere)
    add("sphere_random", "sphere: 2000 random samples", "points", _random_sphere(), sphere)
    add("torus_points", "torus: trimesh torus() vertices", "points",
        DataMesh(np.asarray(tm.creation.torus(1.0, 0.3).vertices, float)), rp.Torus(1.0, 0.3))
    return cases


# ------------------------------------------------------------------------------ settings
def parse_setting(text):
    """``NAME:key=value,...`` (or ``default``) as ``(name, dict)``."""
    name, _, body = text.partition(":")
    spec = {"alpha": "auto", "alpha_u": "auto", "offset": "auto", "cap": "", "weights": "auto"}
    if name == "today" and not body:
        spec["offset"] = "0"
    for item in filter(None, body.split(",")):
        key, _, value = item.partition("=")
        if key not in spec or not value:
            raise SystemExit(f"error: setting {text!r}: unknown or empty key {key!r} "
                             f"(keys: alpha, alpha_u, offset, cap, weights)")
        spec[key] = value
    return name, spec


def spacing(field):
    """Mean edge length of the data (triangles: their edges), or the points' median
    spacing."""
    m = field.mesh
    if m.kind == "points":
        return field.point_spacing()
    E = m.edges if m.kind == "edges" else np.concatenate(
        [m.triangles[:, [0, 1]], m.triangles[:, [1, 2]], m.triangles[:, [2, 0]]])
    E = np.unique(np.sort(E, axis=1), axis=0)
    return float(np.mean(np.linalg.norm(m.V[E[:, 0]] - m.V[E[:, 1]], axis=1)))


def resolve(spec, h, diagonal):
    """``(alpha, alpha_u, offset)`` arguments of ``render_mesh`` for a setting (offset None:
    ``"auto"``)."""
    o = spec["offset"]
    c = None if o == "auto" else float(o[:-1]) * h if o.endswith("h") else float(o)
    if spec["cap"]:
        if c is None:
            raise SystemExit("error: cap needs a numeric offset")
        c = min(c, float(spec["cap"]) * diagonal)
    a = spec["alpha"]
    if a.endswith("/c") and c is None:
        raise SystemExit("error: alpha=M/c needs a numeric offset")
    if a.endswith("/c"):
        alpha = float(a[:-2]) / c
    elif a.endswith("/h"):
        alpha = float(a[:-2]) / h
    else:
        alpha = a if a == "auto" else float(a)
    u = spec["alpha_u"]
    if u.endswith("x"):
        if alpha == "auto":
            raise SystemExit("error: alpha_u=Kx needs a numeric alpha")
        alpha_u = float(u[:-1]) * alpha
    else:
        alpha_u = u if u in ("auto", "off") else float(u)
    return alpha, alpha_u, c


# ------------------------------------------------------------------------------ running
def run_case(name, case, setting, size, beta):
    label, kind, data, shape = case
    field = SmoothDistanceField(data)
    h = spacing(field)
    alpha, alpha_u, c = resolve(setting[1], h, field.diagonal)
    common = dict(kind=kind, size=(size, size), shading="normals", beta=beta, up="z")
    res = tracer.render_mesh(field.mesh, view="iso", alpha=alpha, alpha_u=alpha_u, offset=c,
                             weights=setting[1]["weights"], **common)
    o = res.scene.objects[0]
    c = o.smooth_offset
    smooth = rp.ripple(res, shape)
    r = rp.mean_offset(res, field)
    cam = (res.scene.camera_origin, res.scene.camera_dest, res.scene.camera_up)
    ex = tracer.render_mesh(field.mesh, mode="exact", offset=r, camera=cam, eps=res.scene.eps,
                            alpha=o.alpha, **common)
    exact = rp.ripple(ex, shape)
    bound = max(TARGET_DEG, TARGET_RATIO * exact["p95"])
    return {"case": name, "shape": label, "kind": kind, "setting": setting[0],
            "alpha": o.alpha, "alpha_u": o.alpha_u, "offset": c, "spacing": h,
            "alpha_offset": o.alpha * c, "mean_offset": r,
            "smooth_p50": smooth["p50"], "smooth_p95": smooth["p95"], "hits": smooth["hits"],
            "exact_p50": exact["p50"], "exact_p95": exact["p95"],
            "meets_target": bool(smooth["p95"] <= bound),
            "smooth_s": res.seconds, "exact_s": ex.seconds}


COLUMNS = ("case", "kind", "setting", "alpha", "alpha_u", "offset", "alpha_offset",
           "mean_offset", "smooth_p50", "smooth_p95", "exact_p50", "exact_p95", "meets_target",
           "smooth_s", "exact_s")


def print_row(row, header=False):
    fmt = "{:<15} {:<9} {:<10} {:>8} {:>8} {:>7} {:>6} {:>7} {:>6} {:>6} {:>6} {:>6} {:>4} {:>6} {:>6}"
    if header:
        print(fmt.format("case", "kind", "setting", "alpha", "alpha_U", "c", "a*c", "r mean",
                         "s p50", "s p95", "e p50", "e p95", "ok", "s [s]", "e [s]"))
        return
    print(fmt.format(row["case"], row["kind"], row["setting"][:10], f"{row['alpha']:.4g}",
                     f"{row['alpha_u']:.4g}", f"{row['offset']:.3g}",
                     f"{row['alpha_offset']:.3g}", f"{row['mean_offset']:.3g}",
                     f"{row['smooth_p50']:.1f}", f"{row['smooth_p95']:.1f}",
                     f"{row['exact_p50']:.1f}", f"{row['exact_p95']:.1f}",
                     "yes" if row["meets_target"] else "no", f"{row['smooth_s']:.2f}",
                     f"{row['exact_s']:.2f}"), flush=True)


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--settings", nargs="+", default=["default"], metavar="SETTING")
    p.add_argument("--cases", nargs="+", metavar="NAME", help="default: all")
    p.add_argument("--size", type=int, default=256)
    p.add_argument("--beta", type=float, default=0.5)
    p.add_argument("--threads", type=int)
    p.add_argument("--out", default=str(ROOT / "renders" / "ripple" / "ripple.csv"),
                   help="CSV file (a .json of the same rows is written next to it)")
    return p.parse_args(argv)


def main(argv=None):
    args = parse_args(argv)
    if args.threads:
        numba.set_num_threads(args.threads)
    settings = [parse_setting(s) for s in args.settings]
    cases = build_cases()
    names = args.cases or list(cases)
    unknown = [n for n in names if n not in cases]
    if unknown:
        raise SystemExit(f"error: unknown case(s) {', '.join(unknown)} (cases: "
                         f"{', '.join(cases)})")
    out = Path(args.out)
    if out.suffix != ".csv":
        raise SystemExit(f"error: --out must name a .csv file, got {out}")
    # compile once before timing anything
    tracer.render_mesh(cases["ico2"][2], size=(8, 8), shading="normals", view="iso")
    tracer.render_mesh(cases["ico2"][2], size=(8, 8), shading="normals", view="iso",
                       mode="exact")
    rows = []
    print_row(None, header=True)
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeshRepairWarning)   # pyvista seams, merged
        for setting in settings:
            for name in names:
                row = run_case(name, cases[name], setting, args.size, args.beta)
                rows.append(row)
                print_row(row)
    print(f"{len(rows)} rows in {time.perf_counter() - t0:.0f} s; target: smooth p95 <= "
          f"max({TARGET_DEG:g}, {TARGET_RATIO:g} x exact p95)")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".csv.tmp")
    with open(tmp, "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    os.replace(tmp, out)
    meta = {"date": datetime.date.today().isoformat(), "size": args.size, "view": "iso",
            "beta": args.beta, "threads": numba.get_num_threads(),
            "settings": args.settings, "target": f"smooth p95 <= max({TARGET_DEG:g} deg, "
                                                   f"{TARGET_RATIO:g} x exact p95)",
            "command": "python benchmarks/bench_ripple.py " + " ".join(sys.argv[1:] if argv is None else argv),
            "rows": rows}
    jtmp = out.with_suffix(".json.tmp")
    jtmp.write_text(json.dumps(meta, indent=2) + "\n", encoding="utf-8")
    os.replace(jtmp, out.with_suffix(".json"))
    print(f"wrote {out} and {out.with_suffix('.json')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
