"""
Points, edges or triangles of one mesh
======================================

The smooth distance treats every primitive kind alike (paper Sec. 3): the same bunny as its
vertices (a point cloud), its edges (a wire frame) and its triangles gives three different
smooth surfaces. ``kind=`` picks the primitives; ``"mixed"`` uses everything a file holds in
one tree.
"""

import matplotlib.pyplot as plt

import tracer

fig, axes = plt.subplots(1, 3, figsize=(9, 3.3))
for ax, kind in zip(axes, ["points", "edges", "triangles"]):
    res = tracer.render_mesh("../scenes/data/meshes/bunny_low.obj", kind=kind, size=(200, 200))
    ax.imshow(res.rgb)
    ax.set_title(f"{kind}: alpha {res.scene.objects[0].alpha:.0f}")
    ax.set_axis_off()
plt.tight_layout()
