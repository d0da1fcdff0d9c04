"""Regenerate the README and docs gallery: ``renders/gallery/*.png``.

Every shipped scene of ``scenes/`` at 512 x 512 in the lit look with 16 adaptive samples per
pixel (the scene's camera, data, alpha and beta unchanged), the side-by-side panel of the
authors' normal colours against ours (``look_side_by_side.png``, the bunny of triangles), shapes
of trimesh and pyvista with ``tracer.render_mesh``'s defaults (``own_meshes.png``) and the
whole-mesh distance demo (``mesh_distance.png``, ``examples/mesh_distance_demo.py``).

Usage (from the repository root; about 10 minutes on 2 cores)::

    python examples/make_gallery.py                  # everything
    python examples/make_gallery.py trefoil mixed    # only these scenes
"""

import argparse
import os
import runpy
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run from a checkout without installing
    sys.path.insert(0, str(ROOT))

#: the gallery look: what every scene is rendered with, over the scene file's own settings
LOOK = {"width": 512, "height": 512, "shading": "lit", "samples": 16, "adaptive": True}


def render_scene(name, out_dir, overrides=LOOK):
    """Render ``scenes/<name>.json`` with ``overrides`` to ``out_dir/<name>.png``; return it."""
    from tracer import render
    from tracer.scenes.scene import load_scene

    res = render(load_scene(str(ROOT / "scenes" / f"{name}.json"), dict(overrides)))
    res.save(str(out_dir / f"{name}.png"))
    return res


def side_by_side(out_dir):
    """``look_side_by_side.png``: the bunny of triangles in the paper's normal colours (one
    sample per pixel, as the authors' renderer draws it) beside the gallery look."""
    from tracer import render
    from tracer.scenes.scene import load_scene

    path = str(ROOT / "scenes" / "bunny_triangles.json")
    size = {"width": 384, "height": 384}
    authors = render(load_scene(path, dict(size, shading="normals", samples=1, adaptive=False)))
    ours = render(load_scene(path, dict(LOOK, **size)))
    _panels(out_dir / "look_side_by_side.png",
            ((authors.rgb, "authors' shading (normals)"),
             (ours.rgb, "ours: lit, 16 adaptive samples")), (7.68, 4.0), 9)


def own_meshes(out_dir, size=384):
    """``own_meshes.png``: shapes made in a line of trimesh or pyvista, each drawn by
    ``tracer.render_mesh(shape)`` with every default (the first call of a new user)."""
    import pyvista as pv
    import trimesh

    import tracer

    shapes = (("trimesh annulus", trimesh.creation.annulus(0.5, 1.0, height=0.3)),
              ("pyvista dodecahedron", pv.PlatonicSolid("dodecahedron").triangulate()),
              ("pyvista arrow", pv.Arrow().triangulate()),
              ("pyvista Text3D", pv.Text3D("Hi", depth=0.2).triangulate()),
              ("octopus, 898 triangles", str(ROOT / "scenes" / "data" / "meshes"
                                              / "octopus_low.obj")),
              ("20,000 random samples of a box",
               trimesh.sample.sample_surface(trimesh.creation.box(), 20_000, seed=0)[0]))
    images = [(tracer.render_mesh(shape, size=(size, size), progress=None).rgb, title)
              for title, shape in shapes]
    _panels(out_dir / "own_meshes.png", images, (3.2 * len(shapes), 3.4), 10)


def _panels(path, images, figsize, fontsize):
    """``images`` (``(rgb, title)`` pairs) side by side in one PNG at ``path``, written whole
    or not at all."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(images), figsize=figsize, dpi=100)
    for ax, (rgb, title) in zip(axes, images):
        ax.imshow(rgb)
        ax.set_title(title, fontsize=fontsize)
        ax.axis("off")
    fig.tight_layout()
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp)
    plt.close(fig)
    os.replace(tmp, path)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scenes", nargs="*", help="scene names (default: every scenes/*.json)")
    p.add_argument("--out", default=str(ROOT / "renders" / "gallery"))
    args = p.parse_args(argv)
    out_dir = Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)
    names = args.scenes or sorted(f.stem for f in (ROOT / "scenes").glob("*.json"))
    for name in names:
        res = render_scene(name, out_dir)
        print(f"{name}: {int(res.hit.sum())} hit pixels -> {out_dir / (name + '.png')}",
              flush=True)
    if not args.scenes:
        side_by_side(out_dir)
        print(f"look_side_by_side -> {out_dir / 'look_side_by_side.png'}", flush=True)
        own_meshes(out_dir)
        print(f"own_meshes -> {out_dir / 'own_meshes.png'}", flush=True)
        demo = runpy.run_path(str(ROOT / "examples" / "mesh_distance_demo.py"))
        with tempfile.TemporaryDirectory() as tmp:
            demo["main"](["--out", tmp, "--gallery", str(out_dir / "mesh_distance.png")])
    return 0


if __name__ == "__main__":
    sys.exit(main())
