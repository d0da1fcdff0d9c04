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
* **seams on flat faces** (:func:`flat_seams`, triangles only): on the *flat pixels*, those
  whose :data:`FLAT_WINDOW` x :data:`FLAT_WINDOW` neighbourhood all lies over one plane of
  the mesh (the plane of the triangle nearest each hit point, coplanar triangles sharing it,
  and the hit point's distance to that plane its distance to the mesh: its closest point
  lies inside a face, not on the rounded offset of an edge or a corner),
  the share of normals turned more than :data:`TURN_DEG` from the plane's normal, their p99
  and largest angle, and the share of pixels more than :data:`LEVELS` sRGB levels of
  luminance off the median of their 5 x 5 neighbourhood (in the lit shading, where the shadow
  and the ambient occlusion are even across that neighbourhood: the edge of a shadow is a true
  step). A flat face is one plane: a seam along the internal edges between its triangles
  shows in all four.

:func:`fidelity` returns them with what they were measured on; ``benchmarks/bench_fidelity.py``
runs a corpus of shapes made by trimesh and pyvista, real meshes, scans and curves.
"""

import numpy as np

from smoothdist import SmoothDistanceField
from tracer.rendering.camera import pixel_points
from tracer.rendering.ripple import mean_offset
from tracer.scenes.from_mesh import render_mesh

__all__ = ["fidelity", "flat_seams", "plane_ids", "THIN_OFFSET", "INSIDE", "AGREE_DEG",
           "DARKER", "FLAT_WINDOW", "TURN_DEG", "LEVELS", "EVEN_LIGHT"]

#: offset of the reference silhouette, as a fraction of the bbox diagonal
THIN_OFFSET = 0.0025
#: pixels inside both silhouettes where normals and light are compared
INSIDE = 2
#: normals within this angle (degrees) "agree"
AGREE_DEG = 10.0
#: "much darker": this many sRGB levels of luminance (0-255) below the exact surface's
DARKER = 40.0
#: flat pixels: every pixel of this square neighbourhood lies over the same plane of the mesh
FLAT_WINDOW = 7
#: a flat pixel's normal "turns" when it is more than this many degrees from the plane's
TURN_DEG = 1.0
#: a lit flat pixel is "off" when its luminance is more than this many sRGB levels from the
#: median of its 5 x 5 neighbourhood
LEVELS = 4.0
#: the light is even over a neighbourhood when its shadow and ambient occlusion (0-1) vary by
#: at most this much there
EVEN_LIGHT = 0.02


def _luminance(rgb):
    rgb = np.asarray(rgb, dtype=np.float64)[..., :3]
    return 0.2126 * rgb[..., 0] + 0.7152 * rgb[..., 1] + 0.0722 * rgb[..., 2]


def _inside(mask, k):
    from scipy.ndimage import binary_erosion  # scipy (sim extra): loaded on use

    return binary_erosion(mask, iterations=k) if k > 0 else mask


def plane_ids(V, T):
    """``(ids (t,) int64, normals (t, 3) float64)``: the plane of every triangle of ``T (t, 3)``
    over the vertices ``V (n, 3)``, numbered so that coplanar triangles share an id (unit
    normal up to sign and offset, rounded to 1e-4 of a unit and of the bbox diagonal), and
    each triangle's unit normal (0 for a degenerate one, which gets an id of its own)."""
    V = np.asarray(V, dtype=np.float64)
    T = np.asarray(T, dtype=np.int64)
    a = V[T[:, 0]]
    n = np.cross(V[T[:, 1]] - a, V[T[:, 2]] - a)
    ln = np.linalg.norm(n, axis=1)
    ok = ln > 0
    n[ok] /= ln[ok, None]
    n[~ok] = 0.0
    first = np.argmax(np.abs(n) > 1e-9, axis=1)                 # sign: first component > 0
    sign = np.where(n[np.arange(n.shape[0]), first] < 0, -1.0, 1.0)
    L = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) if V.size else 1.0
    off = np.einsum("ij,ij->i", n, a) * sign / (L if L > 0 else 1.0)
    key = np.round(np.column_stack([n * sign[:, None], off]) * 1e4).astype(np.int64)
    key[~ok] = np.arange(int((~ok).sum()))[:, None] + np.iinfo(np.int32).max
    _, ids = np.unique(key, axis=0, return_inverse=True)
    return ids.ravel().astype(np.int64), n


def flat_seams(res, source=None):
    """``dict`` of the seam figures on flat faces (module notes) of a render ``res`` of one
    object with triangles: ``flat`` (flat pixels), ``turned_share`` (turned more than
    :data:`TURN_DEG`), ``p95_deg``, ``p99_deg``, ``max_deg``, ``off_share`` (more than
    :data:`LEVELS` off their 5 x 5 median); NaN shares where no pixel is flat or the data has
    no triangles.

    ``source``: a ``(V, F)`` triangle mesh the render's data was sampled from (a point cloud
    of a box's faces): its planes are the flat faces, instead of the data's own triangles."""
    # scipy (sim extra): loaded on use
    from scipy.ndimage import maximum_filter, median_filter, minimum_filter

    out = {"flat": 0, "turned_share": float("nan"), "p95_deg": float("nan"),
           "p99_deg": float("nan"), "max_deg": float("nan"), "off_share": float("nan")}
    field = res.scene.objects[0].field
    if source is not None:
        field = SmoothDistanceField(*source)
    m = field.mesh
    if not m.triangles.shape[0] or not res.hit.any():
        return out
    hit = res.hit
    first_tri = m.points.size + m.edges.shape[0]
    P = pixel_points(res.camera, np.where(hit, res.depth, 0))[hit]
    d, _, prim = field.exact_distance(P, return_closest=True)
    ids, normals = plane_ids(m.V, m.triangles)
    tri = prim - first_tri
    t = np.maximum(tri, 0)
    # over a face: the distance to the triangle's plane is the distance to the mesh
    d_plane = np.abs(np.einsum("ij,ij->i", P - m.V[m.triangles[t, 0]], normals[t]))
    inside = (tri >= 0) & (np.abs(d_plane - d) <= 1e-3 * d + 1e-12 * field.diagonal)
    plane = np.full(hit.shape, -1, dtype=np.int64)
    plane[hit] = np.where(inside, ids[t], -1)
    big = int(plane.max()) + 1
    lo = minimum_filter(np.where(plane >= 0, plane, -1), size=FLAT_WINDOW, mode="constant",
                        cval=-1)
    hi = maximum_filter(np.where(plane >= 0, plane, big), size=FLAT_WINDOW, mode="constant",
                        cval=big)
    flat = hit & (plane >= 0) & (lo == hi)
    out["flat"] = n = int(flat.sum())
    if not n:
        return out
    nrm = np.zeros(hit.shape + (3,))
    nrm[hit] = normals[t]
    cos = np.abs(np.sum(res.normals[flat] * nrm[flat], axis=1))
    angle = np.degrees(np.arccos(np.clip(cos, 0.0, 1.0)))
    lum = _luminance(res.rgb)
    off = np.abs(lum - median_filter(lum, size=5)) > LEVELS
    for name in ("shadow", "ao"):           # the lit shading's light: a shadow edge is a step
        a = res.aovs.get(name) if isinstance(getattr(res, "aovs", None), dict) else None
        if a is not None:
            off &= maximum_filter(a, size=5) - minimum_filter(a, size=5) <= EVEN_LIGHT
    off = off[flat]
    out.update(turned_share=float(np.mean(angle > TURN_DEG)),
               p95_deg=float(np.percentile(angle, 95)),
               p99_deg=float(np.percentile(angle, 99)), max_deg=float(angle.max()),
               off_share=float(np.mean(off)))
    return out


def fidelity(res, **render_options):
    """``dict`` of the three figures (module notes) for ``res``, a render of one object made
    by :func:`tracer.render_mesh` (its scene and camera are reused; ``render_options`` are
    passed to the exact renders, e.g. ``kind`` when the render reduced the data).

    Keys: ``iou``, ``p95_deg``, ``p50_deg``, ``streak_share``, ``offset`` (the render's mean
    offset ``c``, scene units), ``thin_offset``, ``compared`` (pixels compared), ``hits`` (of
    the render), ``hits_exact_thin``, and :func:`flat_seams`'s figures with the prefix
    ``seam_``; NaN where nothing can be compared.
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
    out.update({f"seam_{k}": v for k, v in flat_seams(res).items()})
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
