"""Does a lit render shadow its own surface wrongly? A check by brute force (issue 46 item 3).

A lit render's shadow factor at each centre pixel (``res.aovs["shadow"]``) comes from
:func:`tracer.rendering.lighting.soft_shadow`: a sphere-traced ray from just above the hit
point towards the key light, with a start offset, a distance before which it does not judge the
light and the Barnes-Hut field. :func:`wrongly_dark` recomputes what that ray should see
without any of those: the smooth distance of the render's own surface (``d_hat - C``, Barnes-Hut
off, tolerance pruning within ``tol``) sampled at fixed steps of :data:`STEP` diagonals along
the ray, from :data:`START` diagonals out to where the ray leaves the box the surface
lies in. A pixel is
*wrongly dark* where the render put it in shadow (factor below :data:`DARK`) while, by the
samples, the surface stays clear of the ray by more than the penumbra everywhere along it, on
pixels facing the light (``n . l >= FACING``). Between two samples ``h`` apart the distance
can fall by at most ``h / 2`` (it changes no faster than the exact distance does), so "clear"
is ``k (d_hat - C - h / 2) / t >= 1`` at every sample: the soft shadow's own formula then
gives full light everywhere along the ray, and a pixel counted here is one the render darkened
with no occluder in the way.
"""

import numpy as np

from tracer.rendering.camera import pixel_points
from tracer.rendering.lighting import light_directions

__all__ = ["wrongly_dark", "STEP", "START", "DARK", "FACING"]

#: sample spacing along the light ray, as a fraction of the bbox diagonal
STEP = 0.002
#: the first sample, as a fraction of the diagonal (the surface's own distance next to the
#: start is its own, not an occluder's)
START = 0.004
#: "in shadow": a shadow factor below this
DARK = 0.5
#: pixels whose normal faces the light at least this much (``n . l``)
FACING = 0.1


def wrongly_dark(res, tol=1e-3, max_pixels=4000, seed=0):
    """``dict``: ``dark`` (pixels the render shadowed among those facing the light),
    ``checked`` (of them, how many were checked: at most ``max_pixels``, a random choice),
    ``wrong`` (checked pixels wrongly dark) and ``share`` (``wrong / checked``; NaN when none
    were checked). ``res``: a lit render of one object by :func:`tracer.render_mesh` or
    :func:`tracer.render` (smooth mode)."""
    scene = res.scene
    o = scene.objects[0]
    field = o.field
    L = field.diagonal
    key = light_directions(scene.film.lighting, res.camera, scene.camera.up)[0]
    shadow = res.aovs["shadow"]
    P = pixel_points(res.camera, res.depth)
    facing = res.hit & (res.normals @ key >= FACING)
    dark = facing & (shadow < DARK)
    idx = np.flatnonzero(dark)
    rng = np.random.default_rng(seed)
    if idx.size > max_pixels:
        idx = np.sort(rng.choice(idx, max_pixels, replace=False))
    out = {"dark": int(dark.sum()), "checked": int(idx.size), "wrong": 0,
           "share": float("nan")}
    if idx.size == 0:
        return out
    start = P.reshape(-1, 3)[idx]
    lo, hi = field.bounds
    # where each ray leaves the box that holds the surface: the data's, grown by the offset
    # and the inflation bound (the surface lies within them) and 5 % of the diagonal
    pad = 0.05 * L + o.smooth_offset + field.inflation(o.alpha, o.alpha_u)
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = np.where(key > 0, (hi + pad - start) / key, (lo - pad - start) / key)
    t_exit = np.nanmin(np.where(np.isfinite(t1), t1, np.inf), axis=1)
    k = 1.0 / scene.film.lighting.penumbra
    clear = np.ones(idx.size, dtype=bool)
    C = o.smooth_offset
    t = START * L
    while t < t_exit.max() and clear.any():
        live = clear & (t < t_exit)
        if not live.any():
            break
        X = start[live] + t * key
        d = field.smooth_distance(X, alpha=o.alpha, alpha_u=o.alpha_u, beta=0.0,
                                  tol=tol).distance - C
        clear[np.flatnonzero(live)[k * (d - 0.5 * STEP * L) / t < 1.0]] = False
        t += STEP * L
    out["wrong"] = int(clear.sum())
    out["share"] = float(clear.mean())
    return out
