"""
Render a mesh in one call
=========================

``tracer.render_mesh`` takes a file path, ``(V, F)`` arrays, a trimesh or pyvista object and
returns numpy arrays: the image, the depth, the normals. ``alpha="auto"`` (the default) picks
the smoothest surface whose mean offset from the data stays within 2 % of its diagonal, and
the camera frames everything the surface can reach.
"""

import matplotlib.pyplot as plt

import tracer

res = tracer.render_mesh("../scenes/data/meshes/octopus_low.obj", size=(240, 240), view="iso")
obj = res.scene.objects[0]
print(f"alpha {obj.alpha:.1f}, alpha_U {obj.alpha_u:.0f}, {res.hit.mean():.0%} of pixels hit")

fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(8, 4))
ax0.imshow(res.rgb)
ax0.set_title("image (the default lit look)")
ax1.imshow(res.depth, cmap="magma")
ax1.set_title("depth")
for ax in (ax0, ax1):
    ax.set_axis_off()
plt.tight_layout()
