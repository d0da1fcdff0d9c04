"""
Sharpness: what alpha does
==========================

``alpha`` (1 / scene units) sets how far the smooth surface lies from the data: the surface
is the zero set of ``d_hat - 1/alpha`` traced by the sphere tracer, and ``d_hat`` lies between
``d - log(A^S N)/alpha`` and the exact distance ``d``. Low alpha blurs a curve into a blob;
high alpha approaches a thin tube around it. ``"auto"`` picks the smoothest alpha whose mean
offset stays within 2 % of the bounding-box diagonal.
"""

import matplotlib.pyplot as plt

import tracer

curve = "../scenes/data/curves/trefoil.obj"
auto = tracer.render_mesh(curve, kind="edges", size=(180, 180))
a0 = auto.scene.objects[0].alpha
fig, axes = plt.subplots(1, 4, figsize=(10, 2.9))
for ax, alpha in zip(axes, [a0 / 10, a0 / 4, a0 / 2, a0]):
    res = tracer.render_mesh(curve, kind="edges", alpha=alpha, size=(180, 180))
    ax.imshow(res.rgb)
    ax.set_title(f"alpha {alpha:.1f}" + (" (auto)" if alpha == a0 else ""), fontsize=10)
    ax.set_axis_off()
plt.tight_layout()
