"""Demo: the smooth distance between two meshes, and where its gradient acts.

A sphere (triangles) is placed next to the Stanford bunny (triangles) with a small gap. We evaluate
``smoothdist.MeshDistance`` (Madan & Levin 2022, Eq. 6-8) and render both meshes with the sphere
tracer (exact distance, a thin offset shell, headlight shading); the sphere is coloured by the
magnitude of the gradient at its vertices, interpolated over its triangles. The gradient
concentrates on the few vertices facing the bunny: that is the contact "force" a rigid-body solver
would apply.

Usage (from the repository root)::

    python examples/mesh_distance_demo.py                   # renders/mesh_distance/ (+ PNG, JSON)
    python examples/mesh_distance_demo.py --size 256 --gallery renders/gallery/mesh_distance.png
"""

import argparse
import json
import os
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from smoothdist import DataMesh, MeshDistance, SmoothDistanceField  # noqa: E402
from tracer.rendering.camera import primary_rays  # noqa: E402
from tracer.image import save_png  # noqa: E402
from tracer.outputs import atomic_write  # noqa: E402
from tracer.rendering.renderer import render  # noqa: E402
from tracer.scenes.scene import Scene, SceneObject  # noqa: E402

BUNNY = REPO / "scenes" / "data" / "bunny.off"


def sphere(radius, subdivisions=2):
    """Icosphere ``(V, F)`` centred at the origin (trimesh's construction)."""
    import trimesh

    ico = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    return np.asarray(ico.vertices), np.asarray(ico.faces)


def vertex_values_at(points, V, F, values):
    """Interpolate per-vertex ``values`` at the closest points of ``points`` on mesh ``(V, F)``."""
    field = SmoothDistanceField(V, F)
    d, g, tri = field.exact_distance(points, return_closest=True)
    C = points - d[:, None] * g                          # closest points on the mesh
    A, B, Cv = V[F[tri, 0]], V[F[tri, 1]], V[F[tri, 2]]
    e0, e1, e2 = B - A, Cv - A, C - A
    d00 = np.einsum("ij,ij->i", e0, e0)
    d01 = np.einsum("ij,ij->i", e0, e1)
    d11 = np.einsum("ij,ij->i", e1, e1)
    d20 = np.einsum("ij,ij->i", e2, e0)
    d21 = np.einsum("ij,ij->i", e2, e1)
    den = d00 * d11 - d01 * d01
    s = np.clip((d11 * d20 - d01 * d21) / den, 0, 1)
    t = np.clip((d00 * d21 - d01 * d20) / den, 0, 1)
    return (1 - s - t) * values[F[tri, 0]] + s * values[F[tri, 1]] + t * values[F[tri, 2]]


def run(size, out_dir, gallery=None, alpha=200.0, alpha_q=200.0):
    bunny = DataMesh.load(BUNNY)
    Vs, Fs = sphere(0.035)
    md = MeshDistance(bunny, (Vs, Fs), alpha=alpha, alpha_q=alpha_q, beta=0.5)
    t = md.translation_at_gap(0.004, [-1.0, 0.0, 0.0], start=[0.25, 0.085, 0.01])
    d, G = md(t=t)
    de, _ = md.exact(t=t)
    gnorm = np.linalg.norm(G, axis=1)
    Vq = Vs + t

    # trace both meshes: exact distance minus a thin offset (so they look like the meshes)
    shell = 0.0015
    objs = []
    for name, field in (("bunny", md.field), ("sphere", SmoothDistanceField(Vq, Fs))):
        objs.append(SceneObject(name=name, field=field, alpha=alpha, alpha_u=alpha, beta=0.5,
                                offset=shell))
    eye = np.array([-0.01, 0.13, 0.24])      # front left: the side facing the bunny is in view
    look = np.array([0.075, 0.09, 0.0])
    scene = Scene(path="mesh_distance.json", camera_origin=eye, camera_dest=look,
                  camera_up=np.array([0.0, 1.0, 0.0]), objects=objs, width=size, height=size,
                  mode="exact", shading="headlight", eps=2e-5)
    res = render(scene)

    # colour the sphere's pixels by |grad| at its vertices (log scale), shade by the headlight
    dirs = primary_rays(res.camera)
    X = (res.camera.origin + res.depth.astype(np.float64)[..., None] * dirs).reshape(-1, 3)
    hit = res.hit.ravel() & np.all(np.isfinite(X), axis=1)
    on_sphere = np.zeros_like(hit)
    idx = np.flatnonzero(hit)
    if idx.size:
        db = md.field.exact_distance(X[idx])[0]
        ds = objs[1].field.exact_distance(X[idx])[0]
        on_sphere[idx[ds < db]] = True
    floor = 1e-6
    rel = np.log10(np.maximum(gnorm / gnorm.max(), floor))
    vals = np.full(hit.size, np.nan)
    sel = np.flatnonzero(on_sphere)
    if sel.size:
        vals[sel] = vertex_values_at(X[sel], Vq, Fs, rel)
    import matplotlib

    cmap = matplotlib.colormaps["inferno"]
    unit = np.clip((vals - np.log10(floor)) / -np.log10(floor), 0, 1)
    col = cmap(np.nan_to_num(unit))[:, :3]
    light = (res.rgb.reshape(-1, 3).astype(np.float64) / 255.0) / 0.8     # headlight factor
    rgb = res.rgb.reshape(-1, 3).astype(np.float64) / 255.0
    rgb[sel] = np.clip(col[sel] * (0.35 + 0.65 * light[sel]), 0, 1)
    rgb = np.rint(255 * rgb).astype(np.uint8).reshape(size, size, 3)

    os.makedirs(out_dir, exist_ok=True)
    save_png(os.path.join(out_dir, "mesh_distance.png"), rgb)
    info = {"alpha": alpha, "alpha_q": alpha_q, "beta": 0.5, "translation": t.tolist(),
            "smooth_distance": d, "exact_distance": de,
            "grad_sum": G.sum(axis=0).tolist(), "max_vertex_grad": float(gnorm.max()),
            "vertices_above_1e-3_of_max": int((gnorm > 1e-3 * gnorm.max()).sum()),
            "render_seconds": res.seconds, "size": size}
    with atomic_write(os.path.join(out_dir, "mesh_distance.json")) as tmp:
        with open(tmp, "w") as fh:
            json.dump(info, fh, indent=1)
    if gallery:
        os.makedirs(os.path.dirname(os.path.abspath(gallery)), exist_ok=True)
        _figure(rgb, gallery, floor, info)
    return info


def _figure(rgb, path, floor, info):
    """The render with a colour bar and the two distances, as a small PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(3.4, 3.6), dpi=100)
    ax.imshow(rgb)
    ax.set_axis_off()
    sm = plt.cm.ScalarMappable(cmap="inferno", norm=plt.Normalize(np.log10(floor), 0))
    cb = fig.colorbar(sm, ax=ax, orientation="horizontal", fraction=0.05, pad=0.02)
    cb.set_label("log10 |dd/dx_k| / max  (sphere vertices)", fontsize=7)
    cb.ax.tick_params(labelsize=7)
    ax.set_title(f"d_hat = {info['smooth_distance']:.4f}, exact gap = {info['exact_distance']:.4f}",
                 fontsize=8)
    fig.tight_layout()
    with atomic_write(path) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description="Render a sphere next to the bunny, coloured by "
                                             "the mesh-distance gradient at its vertices.")
    ap.add_argument("--size", type=int, default=320, help="image width and height (pixels)")
    ap.add_argument("--out", default=str(REPO / "renders" / "mesh_distance"),
                    help="output folder (PNG + JSON)")
    ap.add_argument("--gallery", help="also write an annotated PNG here")
    args = ap.parse_args(argv)
    if not 16 <= args.size <= 4096:
        print(f"error: --size must be in 16..4096, got {args.size}", file=sys.stderr)
        return 2
    try:
        info = run(args.size, args.out, args.gallery)
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(json.dumps(info, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
