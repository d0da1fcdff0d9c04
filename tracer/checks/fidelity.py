"""Fidelity of a default render to the user's own shape, with no analytic shape to compare to.

Three figures for a render ``res`` of some data (``tracer.render_mesh(mesh)``, any options),
each against an exact-distance render of the same data from the same camera
(``mode="exact"``: the offset surface ``d = c``, whose shape is the data's own):

* **silhouette IoU**: the render's hit mask against the exact render at a tiny offset
  (:data:`THIN_OFFSET` of the bbox diagonal): the mesh itself, as a pyvista screenshot would
  show it. A fattened thin part or a closed hole lowers it. Data without triangles has no
  silhouette of its own: point clouds are compared with the exact offset at their median
  spacing (the sample balls cover the sampled surface), curves with the exact tube at the
  render's own mean offset (the tube's radius is a choice; its beads and ribs are not).
* **p95 normal angle** (degrees): against the exact surface at the render's own mean offset
  ``c`` (the mean exact distance from its hit points to the data,
  :func:`tracer.rendering.ripple.mean_offset`). That offset surface is G1 for ``c > 0``: any
  rib, scallop or dimple the smooth surface adds shows as an angle. Measured on the pixels
  :data:`INSIDE` pixels inside both silhouettes (edges of the two silhouettes differ by
  construction).
* **streak share**: of those pixels, the share where the normals agree (within
  :data:`AGREE_DEG`) but the render is much darker (:data:`DARKER` sRGB levels of luminance)
  than the exact surface lit the same way: shadows and occlusion the smooth surface casts on
  itself wrongly.

:func:`fidelity` returns them with what they were measured on; ``benchmarks/bench_fidelity.py``
runs a corpus of shapes made by trimesh and pyvista, real meshes, scans and curves.
"""

import numpy as np

from tracer.rendering.ripple import mean_offset
from tracer.scenes.from_mesh import render_mesh

__all__ = ["fidelity", "THIN_OFFSET", "INSIDE", "AGREE_DEG", "DARKER"]

#: offset of the reference silhouette, as a fraction of the bbox diagonal
THIN_OFFSET = 0.0025
#: pixels inside both silhouettes where normals and light are compared
INSIDE = 2
#: normals within this angle (degrees) "agree"
AGREE_DEG = 10.0
#: "much darker": this many sRGB levels of luminance (0-255) below the exact surface's
DARKER = 40.0


def _luminance(rgb):
    rgb = np.asarray(rgb, dtype=np.float64)[..., :3]
    return 0.2126 * rgb[..., 0] + 0.7152 * rgb[..., 1] + 0.0722 * rgb[..., 2]


def _inside(mask, k):
    from scipy.ndimage import binary_erosion  # scipy (sim extra): loaded on use

    return binary_erosion(mask, iterations=k) if k > 0 else mask


def fidelity(res, **render_options):
    """``dict`` of the three figures (module notes) for ``res``, a render of one object made
    by :func:`tracer.render_mesh` (its scene and camera are reused; ``render_options`` are
    passed to the exact renders, e.g. ``kind`` when the render reduced the data).

    Keys: ``iou``, ``p95_deg``, ``p50_deg``, ``streak_share``, ``offset`` (the render's mean
    offset ``c``, scene units), ``thin_offset``, ``compared`` (pixels compared), ``hits`` (of
    the render), ``hits_exact_thin``; NaN where nothing can be compared.
    """
    scene = res.scene
    o = scene.objects[0]
    field = o.field
    L = field.diagonal if field.diagonal > 0 else 1.0
    common = dict(size=(scene.film.width, scene.film.height), camera=res.camera, progress=None,
                  alpha=o.alpha, up="y")
    common.update(render_options)
    c = mean_offset(res, field)
    mesh = field.mesh
    if mesh.triangles.shape[0]:
        thin_offset = THIN_OFFSET * L
    elif mesh.points.size:
        thin_offset = field.point_spacing()
    else:
        thin_offset = c if np.isfinite(c) and c > 0 else THIN_OFFSET * L
    thin = render_mesh(mesh, mode="exact", offset=thin_offset, shading="normals",
                              **common)
    union = res.hit | thin.hit
    iou = float((res.hit & thin.hit).sum() / union.sum()) if union.any() else float("nan")
    out = {"iou": iou, "offset": c, "thin_offset": thin_offset, "hits": int(res.hit.sum()),
           "hits_exact_thin": int(thin.hit.sum()), "p95_deg": float("nan"),
           "p50_deg": float("nan"), "streak_share": float("nan"), "compared": 0}
    if not np.isfinite(c) or not c > 0:
        return out
    ref = render_mesh(field.mesh, mode="exact", offset=c, shading=scene.film.shading,
                             lighting=scene.film.lighting, color=o.color, **common)
    both = _inside(res.hit, INSIDE) & _inside(ref.hit, INSIDE)
    n = int(both.sum())
    out["compared"] = n
    if not n:
        return out
    cos = np.sum(res.normals[both] * ref.normals[both], axis=1)
    angle = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    out["p95_deg"] = float(np.percentile(angle, 95))
    out["p50_deg"] = float(np.percentile(angle, 50))
    darker = _luminance(res.rgb)[both] < _luminance(ref.rgb)[both] - DARKER
    out["streak_share"] = float(np.mean(darker & (angle <= AGREE_DEG)))
    return out
