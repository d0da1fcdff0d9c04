"""
Sharpness: what alpha does
==========================

``alpha`` (1 / scene units) sets how far the smooth surface lies from the data: the surface
is the zero set of ``d_hat - 1/alpha`` traced by the sphere tracer, and ``d_hat`` lies between
``d - log(A^S N)/alpha`` and the exact distance ``d``. Low alpha blurs a curve into a blob;
high alpha approaches a thin tube around it. The first three panels draw the zero level set
(``d_hat = 0``) at a fraction of the automatic alpha. The last is ``alpha="auto"`` itself,
which chooses alpha, the attenuation alpha_U and a small positive level ``d_hat = offset``
together, so that a thin curve shows as a smooth tube of visible width.
"""

import matplotlib.pyplot as plt

import tracer

curve = "../scenes/data/curves/trefoil.obj"
auto = tracer.render_mesh(curve, kind="edges", size=(180, 180))
a0 = auto.scene.objects[0].alpha
fig, axes = plt.subplots(1, 4, figsize=(10, 2.9))
for ax, alpha in zip(axes[:3], [a0 / 10, a0 / 4, a0 / 2]):
    res = tracer.render_mesh(curve, kind="edges", alpha=alpha, size=(180, 180))
    ax.imshow(res.rgb)
    ax.set_title(f"alpha {alpha:.1f}, level 0", fontsize=10)
axes[3].imshow(auto.rgb)
axes[3].set_title(f"auto: alpha {a0:.0f}, level {auto.scene.objects[0].smooth_offset:.3f}",
                  fontsize=10)
for ax in axes:
    ax.set_axis_off()
plt.tight_layout()
