"""
trimesh and pyvista objects, random samples
===========================================

``render_mesh`` (and every ``smoothdist`` function) takes trimesh and pyvista objects as they
are. Their viewers are z-up, so ``up="auto"`` looks at them with z up. A random sample of a
surface is a point cloud: ``alpha="auto"`` lowers alpha until the gaps between the samples
close. A mesh drawn as ``kind="edges"`` is a wireframe of tubes: a coarse pyvista torus (32 x 12
quads, split into triangles) shows its every edge; a fine one (pyvista's default resolution, 29,000
edges) would be a moire of tubes thinner than a pixel, and ``render_mesh`` warns when that happens.
"""

import matplotlib.pyplot as plt
import pyvista as pv
import trimesh

import tracer

capsule = trimesh.creation.capsule(height=1.0, radius=0.4)
knot = pv.ParametricTorus(ringradius=1.0, crosssectionradius=0.3,
                         u_res=32, v_res=12, w_res=1).clean()
samples = trimesh.creation.icosphere(subdivisions=3).sample(2000, return_index=False)

fig, axes = plt.subplots(1, 3, figsize=(9, 3.6))
for ax, (title, obj, kw) in zip(axes, [
        ("trimesh capsule", capsule, {}),
        ("pyvista torus (coarse), edges", knot, {"kind": "edges", "view": "iso"}),
        ("2,000 random samples", samples, {})]):
    res = tracer.render_mesh(obj, size=(200, 200), **kw)
    ax.imshow(res.rgb)
    ax.set_title(f"{title}\nalpha {res.scene.objects[0].alpha:.0f}", fontsize=9)
    ax.set_axis_off()
plt.tight_layout()
