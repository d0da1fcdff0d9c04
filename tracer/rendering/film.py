"""Pixels from samples: anti-aliasing, adaptive refinement, shading of every sample, alpha.

A render first traces one ray per pixel, through the pixel's own position (the tile kernels of
:mod:`tracer.rendering.march`); those *centre samples* give the depth, normals and hit mask of a
:class:`~tracer.rendering.frame.RenderResult`. With ``samples = N > 1`` every pixel gets ``N - 1``
more rays (:func:`tracer.rendering.march.sample_tasks`) at the offsets of :func:`sample_offsets`: a
low-discrepancy (R2) sequence warped so that the offsets are distributed like a tent filter of
radius one pixel. Every sample then carries the same weight and the pixel is their mean, which
is the tent-filtered image (filter importance sampling); sample 0 is the centre.

``adaptive``: the centre samples of neighbouring pixels are compared (8 neighbours: hit or
miss, object, ground, shaded colour within :data:`COLOR_CONTRAST`); where a pair disagrees
both pixels get :data:`ADAPTIVE_FIRST` (4) samples; silhouette and object-border pixels, and
those whose 4 samples spread by more than :data:`SAMPLE_SPREAD` or saw different things (an
object, another object, nothing), get :data:`ADAPTIVE_SECOND` (8); those whose 8 samples saw
different things get all ``N``. Elsewhere one sample is enough. The samples of a pixel are
traced together between two cone passes over its 3 x 3 block, one from the camera and one back
from beyond the box, which bound where any of them can meet the surface
(:func:`tracer.rendering.march.sample_tasks`, done once per pixel), with over-relaxed steps
(:data:`SAMPLE_OMEGA`), Newton steps down to a grazing cosine of :data:`SAMPLE_NEWTON_COS`
and the scene's hit threshold (:data:`EPS_PX`).

Every sample is shaded (:mod:`tracer.rendering.shading`, or :mod:`tracer.rendering.lighting` for
``"lit"``) and averaged with its coverage: lit colours in linear light (encoded to sRGB at the end),
the other shadings in display values, as they were defined. The alpha of a pixel is the fraction of
its samples that hit the surface (or, transparent with a ground, the ground's shadow: a shadow
catcher). The centre samples' shadow and occlusion are computed at every
:data:`LIGHT_STRIDE`-th pixel of every :data:`LIGHT_STRIDE`-th row and filled in where the
neighbours agree, each of the two on its own (``_fill_light``; shadow edges, occlusion
creases and object borders are computed in full);
the other samples take theirs bilinearly from the centre samples around them that see the same
object (or ground), and are lit afresh where none does.

Lit renders in smooth mode take the normal of every hit from the field at Barnes-Hut beta
:data:`BETA_SHADE` at the same hit point (``_shading_args``, ``_shading_normals``):
the render's own gradient jumps where a far field switches on, which drew ribs across thin
tubes. The centre samples' are computed at every :data:`SHADE_STRIDE`-th pixel of every
:data:`SHADE_STRIDE`-th row and interpolated between where they agree, the other samples'
likewise from the centre samples around them; hit points, coverage and light stay the
render's own.
"""

import numpy as np

from smoothdist.schedule import parallel_tasks, run_tasks
from tracer.rendering import lighting as _lighting
from tracer.rendering import march
from tracer.rendering.camera import box_corners, primary_rays, ray_origins, sample_rays
from tracer.compiling import wait_ahead
from tracer.rendering.frame import (LightArgs, LightBuffers, MarchArgs, SampleBuffers,
                                    SampleRays, TraceOptions)
from tracer.rendering.shading import (load_matcap, shade_headlight, shade_matcap, shade_normals,
                            view_normals)
from tracer.rendering.threads import CHUNK, in_bands, in_chunks

__all__ = ["sample_offsets", "form_image", "ADAPTIVE_FIRST", "ADAPTIVE_SECOND"]

#: samples of a pixel flagged by the adaptive pass before its own samples are compared
ADAPTIVE_FIRST = 4
#: ... then this many where those disagree (and on every silhouette and object border), and
#: all where these still see different things. Measured (256^2 lit bunny against 256 samples,
#: 512^2 for the time): all 16 at once after the first 4 gave error 0.155 / edge error 2.34
#: in 14.5 s; this stage 0.159 / 2.43 in 12.4 s (3,003 of the 4,429 silhouette pixels stop
#: at 8; uniform 16 samples: 0.190 / 2.33). Colour spread among the 8 as a reason to go on
#: (0.02 / 0.1 / 0.2) changed the error by less than its noise (0.158-0.163), for up to 0.3 s
ADAPTIVE_SECOND = 8
#: neighbouring pixels' centre samples (display values, 0-1) that differ by more than this
#: disagree
COLOR_CONTRAST = 0.08
#: samples of a pixel that spread by more than this (display values, any channel) disagree
SAMPLE_SPREAD = 0.02

#: hit threshold of the extra samples, in pixels (see :func:`tracer.rendering.march.sample_tasks`).
#: 0: the scene's eps, unbiased coverage. Measured on the 512^2 lit bunny, adaptive 16: 0.1
#: pixel saves 10 % of the time (0.25: 22 %) but fattens silhouettes (coverage +0.036 on
#: edge pixels at 0.1), so it is off
EPS_PX = 0.0
#: cap of the extra samples' over-relaxed sphere-tracing steps
#: (:func:`tracer.rendering.march.march_ray`: steps lengthened by the slope of the distance along
#: the ray, each one checked). Silhouette samples graze the surface and then leave it, where plain
#: steps grow slowly. Measured on the 512^2 lit bunny, adaptive 16: the samples' distance queries
#: (with the cone passes) 1.07 M with the fixed factor 1.6 of before (which fell back to 1 for good
#: after its first failed step); with the slope rule at ``OMEGA_SAFETY`` 0.9, 809 k capped at 2 or
#: at 3 (at 0.8: 842 k capped at 1.6, 828 k at 3). Camera rays take the same rule
#: (:data:`tracer.rendering.march.OMEGA`, also 2)
SAMPLE_OMEGA = 2.0

#: the extra samples take Newton steps (:func:`tracer.rendering.march.march_ray`) unless
#: ``-(g . dir) < SAMPLE_NEWTON_COS |g|`` (camera rays: :data:`tracer.rendering.march.NEWTON_COS`,
#: 0.2). Silhouette samples graze the surface, where sphere steps converge slowly. Measured on the
#: 512^2 lit bunny, adaptive 16 (before the middle stage): 0.2 -> 27.3 queries per extra ray
#: (30 on hits, 22 on misses), 0.05 -> 22.0, 0.02 -> 19.8 (12 on hits), 0.005 -> 19.4; 18.0 ->
#: 14.6 s; 285 of 262,144 pixels changed, mean alpha change 1e-6. The price: a Newton step
#: along a grazing ray may cross a thin part and land in the surface behind it (the sample
#: then shows that surface; hit or miss is unchanged), 1 of 112 hits in
#: ``tests/tracer/rendering/test_march.py::test_samples_equal_a_plain_march``
SAMPLE_NEWTON_COS = 0.02

_R2 = 1.32471795724474602596     # the plastic number: R2 sequence (Roberts 2018)


def _tent_inverse(u):
    """Inverse CDF of the tent filter ``1 - |x|`` on ``[-1, 1]``."""
    return np.where(u < 0.5, -1.0 + np.sqrt(2.0 * u), 1.0 - np.sqrt(2.0 * (1.0 - u)))


def sample_offsets(n):
    """``(n, 2)`` sub-pixel offsets ``(d_row, d_col)`` in pixels; offset 0 is ``(0, 0)``.

    The R2 sequence started at ``(0.5, 0.5)`` and warped by the tent's inverse CDF: its first
    ``k`` points are well spread for every ``k`` (so the adaptive pass can add samples to a
    pixel in order) and distributed like the tent filter of radius one pixel."""
    k = np.arange(int(n), dtype=np.float64)
    u = np.mod(0.5 + k / _R2, 1.0)
    v = np.mod(0.5 + k / _R2 ** 2, 1.0)
    return np.stack([_tent_inverse(v), _tent_inverse(u)], axis=1)


class _Shader:
    """Shades samples of one render (colours, alphas, objects, light factors)."""

    def __init__(self, scene, camera, arrays, kargs, gpu=None):
        self.scene = scene
        self.gpu = gpu      # tracer.rendering.gpu_render, or None: the CPU
        self.camera = camera
        self.arrays = arrays
        self.kargs = kargs  # tracer.rendering.frame.RayArgs: the render's own queries
        self.lit = scene.film.shading == "lit"
        #: display values of colours: sRGB of linear light (lit), else clipped to [0, 1]
        self.encoder = _lighting.linear_to_srgb if self.lit else _clip01
        self.transparent = bool(getattr(scene, "transparent", False))
        self.nobj = len(scene.objects)
        bg = np.asarray(scene.film.background, dtype=np.float64) / 255.0
        if self.lit:
            light = scene.film.lighting
            self.light = light
            self.key, self.fill, self.up = _lighting.light_directions(light, camera,
                                                                       scene.camera.up)
            self.bg = _lighting.srgb_to_linear(bg)
            self.base = _lighting.srgb_to_linear(np.array(
                [_object_color(o, i, self.nobj) for i, o in enumerate(scene.objects)]) / 255.0)
            self.ground_base = _lighting.srgb_to_linear(np.asarray(light.ground_color) / 255.0)
            self.diag = scene.diagonal
            if not self.diag > 0:   # data of no extent (one point): the surface's box
                self.diag = float(np.linalg.norm(np.asarray(arrays.hi) - np.asarray(arrays.lo)))
            # the ground fades out around the box that holds the surface
            box_lo, box_hi = np.asarray(arrays.lo), np.asarray(arrays.hi)
            self.centre = 0.5 * (box_lo + box_hi)
            self.fade_radius = FADE * float(np.linalg.norm(box_hi - box_lo))
            self.ground = None
            if light.ground:
                verts = np.concatenate([o.field.mesh.V for o in scene.objects]) \
                    if arrays.params.shape[1] == march.P_COLUMNS else None
                if verts is not None:
                    self.ground = _lighting.ground_height(arrays, verts, self.up, scene.march.eps)
                else:   # posed objects: the bottom of the posed scene box
                    self.ground = float((box_corners(arrays.lo, arrays.hi) @ self.up).min())
            self.queries = 0
            self.leaves = 0
            self.slack = _lighting.LIGHT_SLACK * self.diag   # 0: the render's own queries
        else:
            self.bg = bg
            if scene.film.shading == "matcap":
                self.matcap = load_matcap(scene.film.matcap)

    # ------------------------------------------------------------------ pieces
    def objects_at(self, P):
        if self.nobj == 1 or len(P) == 0:
            return np.zeros(len(P), dtype=np.int64)
        tree, roots, params, mode, lo, hi, depth_max, tol = self.arrays
        out = np.empty(len(P), dtype=np.int64)
        march_roots = roots if np.ndim(roots) else np.asarray([roots], dtype=np.int64)
        _lighting.object_ids(tree, (march_roots, params, mode, tol), np.ascontiguousarray(P),
                             depth_max, out, parallel_tasks(len(P)))
        return out

    def light_at(self, P, N, shadows=True, ao=True, ground=False):
        """Shadow and occlusion at points with normals (the kernel, batched); ``shadows`` /
        ``ao`` False: that factor is not computed (returned as 1). ``ground``: the points are
        on the ground, whose shadow rays judge the light from their start (the surface above
        is an occluder there, not the start's own relief: marched through, it left the ground
        lit under a point cloud's base)."""
        n = len(P)
        do_shadow = bool(shadows and self.light.shadows)
        do_ao = bool(ao and self.light.ao)
        shadow = np.ones(n)
        ao = np.ones(n)
        if n == 0 or not (do_shadow or do_ao):
            return shadow, ao
        k = self.kargs                      # the render's own queries
        tree, roots, params, mode, tol = k.tree, k.roots, k.params, k.mode, k.tol
        lo, hi, depth_max = self.arrays.lo, self.arrays.hi, self.arrays.depth_max
        eps = float(self.scene.march.eps)
        if self.ground is not None:     # shadow rays may start on the ground, below the box
            lo, hi = _box_with_ground(lo, hi, self.up, self.ground)
        work = np.zeros((n, 2), dtype=np.int64)
        P = np.ascontiguousarray(P)
        N = np.ascontiguousarray(N)
        k = 1.0 / self.light.penumbra
        delta = self.light.ao_distance * self.diag / _lighting.AO_SAMPLES
        t_min = max(2.0 * eps, _lighting.SHADOW_START * self.diag)
        t_judge = t_min if ground else _lighting.SHADOW_JUDGE * t_min
        ntasks = parallel_tasks(n)
        light = LightArgs(self.key, lo, hi, eps, k, delta, do_shadow, do_ao, self.slack, t_min,
                          t_judge)
        out = LightBuffers(shadow, ao, work)
        if self.gpu is not None:
            self.gpu.light_points_cuda(tree, (roots, params, mode, tol), (P, N), light, out)
        else:
            run_tasks(lambda a, b: _lighting.light_tasks(
                tree, (roots, params, mode, tol), (P, N), depth_max, light, out,
                (ntasks, a, b)), ntasks)
        self.queries += int(work[:, 0].sum())
        self.leaves += int(work[:, 1].sum())
        return shadow, ao

    def ground_hits(self, rays, miss):
        """``(on_ground (n,) bool, points (n, 3), fade (n,))`` for camera rays ``rays =
        (origins, dirs)`` (:func:`tracer.rendering.camera.sample_rays`)."""
        origins, dirs = rays
        n = len(dirs)
        on = np.zeros(n, dtype=bool)
        pts = np.zeros((n, 3))
        fade = np.zeros(n)
        if self.ground is None or not miss.any():
            return on, pts, fade
        # the ground fades into the background away from the object (a studio floor)
        below = self.centre - (self.centre @ self.up - self.ground) * self.up

        def chunk(a, b):                  # each ray on its own
            org = _at(origins, slice(a, b))
            height = self.ground - org @ self.up
            du = dirs[a:b] @ self.up
            t = height / np.where(du < 0, du, -1.0)
            idx = np.flatnonzero(miss[a:b] & (du < -1e-9) & (t > 0) & np.isfinite(t))
            p = _at(org, idx) + t[idx, None] * dirs[a:b][idx]
            f = np.exp(-(_norm3(p - below) / self.fade_radius) ** 2)
            # where the ground has faded into the background it is background (no light)
            keep = f >= GROUND_MIN_FADE
            pts[a:b][idx] = p
            on[a:b][idx[keep]] = True
            fade[a:b][idx[keep]] = f[keep]
        in_chunks(chunk, n)
        return on, pts, fade

    # ------------------------------------------------------------------ samples
    def shade(self, hit, t, grad, rays, reuse=None, grid=None, objs=None):
        """Colours ``(n, 3)`` (linear if lit, display values otherwise), alphas ``(n,)`` and a
        record of what each sample saw (for reuse by later samples of the same pixel), of
        samples along the camera rays ``rays = (origins, dirs)``
        (:func:`tracer.rendering.camera.sample_rays`).

        ``objs (n,)``: the object each hit shows, as the march found it at the hit
        (:func:`tracer.rendering.march.march_ray`); None: found here (:meth:`objects_at`).

        ``grid = (H, W)``: the samples are an image's centre samples, whose light is computed
        at every LIGHT_STRIDE-th pixel of every LIGHT_STRIDE-th row and filled in between
        (``_fill_light``)."""
        n = len(hit)
        origins, dirs = rays
        normals = np.empty((n, 3))
        P = np.empty((n, 3)) if self.lit else None

        def geometry(a, b):
            normals[a:b] = _unit(grad[a:b])
            if P is not None:
                P[a:b] = (_at(origins, slice(a, b))
                          + np.where(hit[a:b], t[a:b], 0.0)[:, None] * dirs[a:b])
        in_chunks(geometry, n)
        if not self.lit:
            nv = view_normals(normals.reshape(n, 1, 3), self.camera)
            h2 = hit.reshape(n, 1)
            if self.scene.film.shading == "matcap":
                rgb = shade_matcap(nv, h2, self.matcap)
            elif self.scene.film.shading == "headlight":
                rgb = shade_headlight(nv, h2)
            else:
                rgb = shade_normals(nv, h2)
            colour = rgb.reshape(n, 3).astype(np.float64) / 255.0
            return colour, hit.astype(np.float64), {"obj": np.zeros(n, np.int64), "hit": hit}
        obj = self.objects_at(P[hit]) if objs is None else np.asarray(objs, np.int64)[hit]
        obj_all = np.full(n, -1, dtype=np.int64)
        obj_all[hit] = obj
        miss = ~hit
        on_ground, G, fade = self.ground_hits(rays, miss)
        shadow = np.ones(n)
        ao = np.ones(n)
        fresh = hit | on_ground
        if reuse is not None:
            key = np.where(hit, obj_all, np.where(on_ground, -2, -1))
            s_i, a_i, same = _interpolated_light(reuse, key)
            same &= fresh
            shadow[same] = s_i[same]
            ao[same] = a_i[same]
            fresh &= ~same
        # the gradient points out of the surface, towards the side the ray came from
        facing = np.empty((n, 3))
        depth = np.empty(n)

        def side(a, b):
            facing[a:b] = np.where(hit[a:b, None], normals[a:b], self.up)
            depth[a:b] = np.where(hit[a:b], t[a:b], _norm3(G[a:b] - _at(origins, slice(a, b))))
        in_chunks(side, n)

        def light(idx, shadows=True, occlusion=True):
            for part, pts, ground in ((idx[hit[idx]], P, False), (idx[~hit[idx]], G, True)):
                if part.size:
                    s_i, a_i = self.light_at(pts[part], facing[part], shadows, occlusion, ground)
                    if shadows:
                        shadow[part] = s_i
                    if occlusion:
                        ao[part] = a_i

        if grid is not None and LIGHT_STRIDE > 1:
            H, W = grid
            on_grid = np.zeros((H, W), dtype=bool)
            on_grid[::LIGHT_STRIDE, ::LIGHT_STRIDE] = True
            coarse = fresh & on_grid.ravel()
            light(np.flatnonzero(coarse))
            key = np.where(hit, obj_all, np.where(on_ground, -2, -1))
            got_s, got_a = _fill_light((H, W), fresh & ~coarse, coarse, key, depth, facing,
                                       shadow, ao, facing @ self.key > 0.0)
            rest = fresh & ~coarse
            light(np.flatnonzero(rest & ~got_s & ~got_a))
            light(np.flatnonzero(rest & ~got_s & got_a), occlusion=False)
            light(np.flatnonzero(rest & got_s & ~got_a), shadows=False)
        else:
            light(np.flatnonzero(fresh))
        colour, alpha = self.colours(hit, obj, normals, dirs, shadow, ao, on_ground, fade)
        record = {"obj": obj_all, "ground": on_ground, "shadow": shadow, "ao": ao, "hit": hit,
                  "on_ground": on_ground}
        return colour, alpha, record

    def colours(self, hit, obj, normals, dirs, shadow, ao, on_ground, fade):
        """Linear colours ``(n, 3)`` and alphas ``(n,)`` of lit samples: the surface's at the
        hits (``obj``: the object of each hit, in order), the ground's where rays meet it
        (``fade``), nothing elsewhere."""
        n = len(hit)
        colour = np.zeros((n, 3))
        alpha = np.zeros(n)
        h = np.flatnonzero(hit)

        def surface(a, b):                  # each hit on its own
            i = h[a:b]
            colour[i] = _lighting.shade_lit(normals[i], dirs[i], self.base[obj[a:b]],
                                            shadow[i], ao[i], self.key, self.fill, self.up,
                                            self.light.exposure)
        in_chunks(surface, h.size)
        alpha[h] = 1.0
        g = np.flatnonzero(on_ground)
        if g.size:
            lit_ground = _lighting.shade_ground(self.ground_base, shadow[g], ao[g], self.key,
                                                self.up, self.light.exposure)
            if self.transparent:     # a shadow catcher: black, as opaque as the shadow is dark
                full = _lighting.shade_ground(self.ground_base, np.ones(1), np.ones(1),
                                              self.key, self.up, self.light.exposure)[0]
                dark = 1.0 - (lit_ground / np.maximum(full, 1e-12)).mean(axis=1)
                alpha[g] = np.clip(fade[g] * dark, 0.0, 1.0)
            else:
                colour[g] = fade[g, None] * lit_ground + (1.0 - fade[g, None]) * self.bg
                alpha[g] = 1.0
        return colour, alpha

    def encode(self, colour):
        """Display values in ``[0, 1]`` of averaged colours ``(n, ...)`` (:attr:`encoder`), in
        chunks of ``n`` over the render's threads (the same values as in one piece)."""
        colour = np.asarray(colour, dtype=np.float64)
        out = np.empty(colour.shape)

        def chunk(a, b):
            out[a:b] = self.encoder(colour[a:b])
        in_chunks(chunk, len(colour))
        return out


#: the centre samples' light is computed at every LIGHT_STRIDE-th pixel of every
#: LIGHT_STRIDE-th row and filled in between where the neighbours agree (1: every pixel)
LIGHT_STRIDE = 3
#: a coarse neighbour fills a pixel in when it sees the same object, its depth is within this
#: fraction of the pixel's and its normal within ``acos(FILL_COS)``
FILL_DEPTH = 0.02
FILL_COS = 0.9
#: ... and, for the shadow, when the coarse neighbours' shadows differ by at most this (else:
#: a shadow edge), for the occlusion when their occlusions do (else: a crease or a contact)
FILL_SHADOW = 0.1
#: ... and only from at least this many such neighbours: one alone cannot tell a pixel by a
#: shadow's edge from one inside it (the brute-force check of ``tracer.checks.self_shadow``
#: found pixels darkened by a single dark neighbour beside a lit sliver)
FILL_SHADOW_NEIGHBOURS = 2
#: ... and only where such neighbours lie on both sides of the pixel along each axis on which
#: it lies between coarse pixels: neighbours on one side alone do not see what changes
#: between them and it (False: the older rule, kept for comparisons; measured in
#: docs/guide/performance.md, "Tuning constants")
FILL_BETWEEN = True
#: the ground fades into the background as ``exp(-(r / R)^2)`` with ``R`` this many times the
#: diagonal of the box that holds the surface (``r``: distance from below its centre) ...
FADE = 0.9
#: ... and is drawn where that is at least this
GROUND_MIN_FADE = 0.01


def _fill_light(shape, want, coarse, key, depth, normals, shadow, ao, lit_side=None):
    """Shadow and occlusion of the pixels ``want`` from the coarse pixels around them.

    Each wanted pixel takes the bilinear-weighted mean of the (up to four) surrounding coarse
    pixels that see the same object (``key``), at a depth within :data:`FILL_DEPTH` and with a
    normal within ``acos(FILL_COS)`` of its own, for its shadow where those neighbours'
    shadows differ by at most :data:`FILL_SHADOW`, and for its occlusion where their
    occlusions do (each factor on its own: a shadow edge over an open floor still takes its
    occlusion from the neighbours). ``lit_side (n,) bool``: the normal faces the key light;
    a coarse pixel fills a pixel's shadow only from the same side of that terminator (facing
    away, the kernel sets the shadow to 0 without tracing a ray: that 0 is no measurement of
    the light on the other side, and filled in there it drew dark specks on the last pixels
    that face the light). Pixels without such a neighbour, or where the neighbours disagree,
    are left out to be lit on their own. Edits ``shadow`` and ``ao`` in place; returns the
    masks ``(shadow filled, occlusion filled)``."""
    H, W = shape
    s = LIGHT_STRIDE
    idx = np.flatnonzero(want)
    got_s = np.zeros(key.size, dtype=bool)
    got_a = np.zeros(key.size, dtype=bool)
    if idx.size == 0:
        return got_s, got_a
    # chunks of the wanted pixels on the render's threads; they read the coarse pixels' light
    # from these copies and write only their own pixels
    src_s, src_a = shadow.copy(), ao.copy()

    def fill(b0, b1):
        i = idx[b0:b1]
        r, c = np.divmod(i, W)
        r0, c0 = (r // s) * s, (c // s) * s
        fr, fc = (r - r0) / s, (c - c0) / s
        acc_s = np.zeros(i.size)
        acc_a = np.zeros(i.size)
        acc_w = np.zeros(i.size)
        acc_ws = np.zeros(i.size)
        n_s = np.zeros(i.size, dtype=np.int64)
        s_lo = np.full(i.size, np.inf)
        s_hi = np.full(i.size, -np.inf)
        a_lo = np.full(i.size, np.inf)
        a_hi = np.full(i.size, -np.inf)
        # which sides of the pixel an agreeing neighbour lies on (rows above, below; columns
        # left, right), for the shadow and for the occlusion
        side_s = np.zeros((4, i.size), dtype=bool)
        side_a = np.zeros((4, i.size), dtype=bool)
        for dr, dc, w in ((0, 0, (1 - fr) * (1 - fc)), (0, s, (1 - fr) * fc),
                          (s, 0, fr * (1 - fc)), (s, s, fr * fc)):
            rr, cc = r0 + dr, c0 + dc
            inside = (rr < H) & (cc < W)
            j = np.where(inside, rr * W + np.minimum(cc, W - 1), 0)
            ok = inside & coarse[j] & (key[j] == key[i]) & (w > 0)
            ok &= np.abs(depth[j] - depth[i]) <= FILL_DEPTH * depth[i]
            ok &= _dot3(normals[j], normals[i]) >= FILL_COS
            wt = np.where(ok, w, 0.0)
            ok_s = ok if lit_side is None else ok & (lit_side[j] == lit_side[i])
            wt_s = np.where(ok_s, w, 0.0)
            acc_s += wt_s * src_s[j]
            acc_a += wt * src_a[j]
            acc_w += wt
            acc_ws += wt_s
            n_s += ok_s
            s_lo = np.where(ok_s, np.minimum(s_lo, src_s[j]), s_lo)
            s_hi = np.where(ok_s, np.maximum(s_hi, src_s[j]), s_hi)
            a_lo = np.where(ok, np.minimum(a_lo, src_a[j]), a_lo)
            a_hi = np.where(ok, np.maximum(a_hi, src_a[j]), a_hi)
            for side, here in enumerate((dr == 0, dr == s, dc == 0, dc == s)):
                if here:
                    side_s[side] |= ok_s
                    side_a[side] |= ok
        # across a shadow's edge, or where the occlusion changes fast, the neighbours
        # disagree: no interpolation of that factor there. Nor where they lie on one side of
        # the pixel only (between two rows of coarse pixels, agreeing ones in both): what
        # changes between them and the pixel is not seen (the contact shadow under an object
        # standing on the ground, whose coarse row above is the object, was filled in lit)
        between_s = ((fr == 0) | (side_s[0] & side_s[1])) & ((fc == 0) | (side_s[2] & side_s[3]))
        between_a = ((fr == 0) | (side_a[0] & side_a[1])) & ((fc == 0) | (side_a[2] & side_a[3]))
        if not FILL_BETWEEN:
            between_s = between_a = True
        good_s = ((acc_ws > 0) & (n_s >= FILL_SHADOW_NEIGHBOURS) & (s_hi - s_lo <= FILL_SHADOW)
                  & between_s)
        good_a = (acc_w > 0) & (a_hi - a_lo <= FILL_SHADOW) & between_a
        shadow[i[good_s]] = acc_s[good_s] / acc_ws[good_s]
        ao[i[good_a]] = acc_a[good_a] / acc_w[good_a]
        got_s[i[good_s]] = True
        got_a[i[good_a]] = True

    in_chunks(fill, idx.size)
    return got_s, got_a


def _interpolated_light(reuse, key):
    """Shadow and occlusion at sub-pixel positions, bilinear from the centre samples of the
    four pixels around each position that see the same thing (``key``: object index, -2 for
    the ground). ``(shadow, ao, ok)``; ``ok`` False where none does."""
    H, W = reuse["shape"]
    r, c = reuse["position"]
    rec = reuse["centre"]
    ckey = np.where(rec["hit"], rec["obj"], np.where(rec["on_ground"], -2, -1))
    r0 = np.floor(r).astype(np.int64)
    c0 = np.floor(c).astype(np.int64)
    fr, fc = r - r0, c - c0
    acc_s = np.zeros(r.size)
    acc_a = np.zeros(r.size)
    acc_w = np.zeros(r.size)
    for dr, dc, w in ((0, 0, (1 - fr) * (1 - fc)), (0, 1, (1 - fr) * fc),
                      (1, 0, fr * (1 - fc)), (1, 1, fr * fc)):
        rr = np.clip(r0 + dr, 0, H - 1)
        cc = np.clip(c0 + dc, 0, W - 1)
        j = rr * W + cc
        ok = (ckey[j] == key) & (w > 0)
        wt = np.where(ok, w, 0.0)
        acc_s += wt * rec["shadow"][j]
        acc_a += wt * rec["ao"][j]
        acc_w += wt
    ok = acc_w > 1e-12
    d = np.where(ok, acc_w, 1.0)
    return acc_s / d, acc_a / d, ok


def _box_with_ground(lo, hi, up, height):
    """The scene box grown to reach the ground plane (along the axis closest to ``up``)."""
    lo = np.array(lo, dtype=np.float64)
    hi = np.array(hi, dtype=np.float64)
    a = int(np.argmax(np.abs(up)))
    if up[a] > 0:
        lo[a] = min(lo[a], height / up[a] - 1e-9)
    else:
        hi[a] = max(hi[a], height / up[a] + 1e-9)
    return lo, hi


def _object_color(obj, i, nobj):
    color = getattr(obj, "color", None)
    if color is not None:
        return np.asarray(color, dtype=np.float64)
    if nobj == 1:
        return np.asarray(_lighting.DEFAULT_COLOR, dtype=np.float64)
    return np.asarray(_lighting.PALETTE[i % len(_lighting.PALETTE)], dtype=np.float64)


def _sample_keys(record):
    """What each sample saw: the object's index, or -1 (background or ground)."""
    return np.where(record["hit"], record["obj"], -1)


def _neighbour_flags(colour, record, shape):
    """Pixels whose centre sample disagrees with one of its 8 neighbours' (both get flagged):
    ``(flags, edges)``, both ``(H W,)`` bool; ``edges``: the disagreement is geometric (hit or
    miss, object), not only a colour contrast."""
    H, W = shape
    c = colour.reshape(H, W, 3)
    # (ground against background is no edge: the ground fades into it; its colour decides)
    keys = [record["hit"].reshape(H, W), record["obj"].reshape(H, W)]
    flags = np.zeros((H, W), dtype=bool)
    edges = np.zeros((H, W), dtype=bool)

    def band(r0, r1):
        # rows r0 <= r < r1 against their 8 neighbours (a pixel's tent filter reaches one
        # pixel into each): each band writes its own rows only
        for dr in (-1, 0, 1):
            a0, a1 = max(r0, -dr), min(r1, H - dr)
            for dc in (-1, 0, 1):
                if (dr, dc) == (0, 0) or a0 >= a1:
                    continue
                a = (slice(a0, a1), slice(max(0, -dc), W - max(0, dc)))
                b = (slice(a0 + dr, a1 + dr), slice(max(0, dc), W - max(0, -dc)))
                geo = np.zeros((a1 - a0, W - abs(dc)), dtype=bool)
                for k in keys:
                    geo |= k[a] != k[b]
                d = np.abs(c[a] - c[b])
                # the largest channel (np.max along the short axis, three times slower)
                flags[a] |= geo | (np.maximum(np.maximum(d[..., 0], d[..., 1]), d[..., 2])
                                   > COLOR_CONTRAST)
                edges[a] |= geo
    in_bands(band, H)
    return flags.ravel(), edges.ravel()


def _trace(kargs, depth_max, options, pixels, W, offsets, bounds=None, eps_px=EPS_PX,
           gpu=None):
    """The samples ``offsets (K, 2)`` of the pixels ``pixels (m,)`` (flat indices), flattened
    pixel-major: ``hit, t, grad, steps, objs`` of length ``m K``. ``bounds = (t_lo, t_hi)``, each
    ``(m,)``: the pixels' cone bounds, read where finite, written where not (NaN). ``eps_px``:
    the rays' hit threshold in pixels (:func:`tracer.rendering.march.sample_tasks`).
    ``gpu``: :mod:`tracer.rendering.gpu_render` to trace on the GPU
    (:func:`~tracer.rendering.gpu_render.trace_samples_cuda`), None on the CPU."""
    tree, roots, params, mode, tol, cam, lo, hi, eps, max_steps = kargs
    relax, omega, cone, newton = options
    omega = max(omega, SAMPLE_OMEGA)
    m, K = pixels.size, len(offsets)
    hit = np.zeros((m, K), dtype=np.bool_)
    t = np.full((m, K), np.nan)
    grad = np.zeros((m, K, 3))
    steps = np.zeros((m, K), dtype=np.int64)
    objs = np.full((m, K), -1, dtype=np.int32)
    if bounds is None:
        bounds = (np.full(m, np.nan), np.full(m, np.nan))
    if m and K:
        rows, cols = np.divmod(pixels.astype(np.int64), W)
        offsets = np.ascontiguousarray(offsets, dtype=np.float64)
        ntasks = parallel_tasks(m)
        ray = MarchArgs(roots, params, mode, tol, cam, lo, hi, eps, max_steps)
        out = SampleBuffers(hit, t, grad, steps, objs, bounds[0], bounds[1])
        opts = TraceOptions(relax, omega, cone, newton)
        samples = SampleRays(rows, cols, offsets, float(eps_px), float(SAMPLE_NEWTON_COS))
        if gpu is not None:
            gpu.trace_samples_cuda(tree, ray, samples, out, opts)
        else:
            wait_ahead("samples")   # a child compiling this kernel (compile_ahead) is done
            run_tasks(lambda a, b: march.sample_tasks(
                tree, ray, samples, depth_max, out, opts, (ntasks, a, b)), ntasks)
    return hit.ravel(), t.ravel(), grad.reshape(-1, 3), steps.ravel(), objs.ravel()


#: lit renders in smooth mode take the normal of each hit sample from the field at Barnes-Hut
#: beta at most this (``_shading_normals``): the far field switches where ``diag < beta
#: x dist``, and the gradient jumps there, which draws ribs across thin tubes in the light
#: (issue 35). Measured: performance guide, "Publication images"
BETA_SHADE = 0.2
#: the centre samples' shading normals are computed at every SHADE_STRIDE-th pixel of every
#: SHADE_STRIDE-th row and interpolated in between where the four around agree ...
SHADE_STRIDE = 3
#: ... on the object, the depth (:data:`FILL_DEPTH`) and the normal, each within
#: ``acos(SHADE_FILL_COS)`` (5 degrees) of their blend; the other samples take theirs from
#: the centre samples around them in the same way
SHADE_FILL_COS = 0.996
#: :func:`_shading_normals` marches with a hit threshold of this many pixels: any distance is
#: a hit, so the march stops at its first evaluation, at the sample's own hit
_ANY_DISTANCE = 1e300


def _shading_args(kargs):
    """``kargs`` (:class:`tracer.rendering.frame.RayArgs`) with the Barnes-Hut beta of every object
    lowered to :data:`BETA_SHADE` (a copy of ``params``), or None where that changes nothing
    (exact-offset mode, or every beta already that low)."""
    params = kargs.params
    if kargs.mode != march.MODE_SMOOTH or not (params[:, march.P_BETA] > BETA_SHADE).any():
        return None
    low = np.array(params, dtype=np.float64, order="C")
    low[:, march.P_BETA] = np.minimum(low[:, march.P_BETA], BETA_SHADE)
    return kargs._replace(params=low)


def _shading_normals(skargs, depth_max, options, pixels, W, offsets, hit, t, grad,
                     gpu=None):
    """The gradient of the shading field ``skargs`` (:func:`_shading_args`) at every hit
    sample, written over ``grad`` in place; ``hit (n,), t (n,), grad (n, 3)`` are flat,
    pixel-major over ``pixels (m,)`` x ``offsets (K, 2)``, as :func:`_trace` returns them.
    The hit points ``t`` stay those of the render's own field (its silhouettes, its light).

    Each ray is marched from its hit ``t`` to ``t`` with a hit threshold that any distance
    meets, so it stops at its first evaluation and returns the gradient there: on the CPU by
    :func:`tracer.rendering.march.gradient_tasks`, which evaluates just that (a kernel of the
    distance alone: a first render compiles it in a fraction of the samples' kernel's time),
    on the GPU by the samples' kernel (:func:`_trace`). Returns the distance evaluations made
    (one per hit on the CPU; on the GPU two where ``tol > 0`` loosens the first)."""
    K = len(offsets)
    evals = 0
    for k in range(K):          # one kernel call per offset: a sample's ray is (pixel, offset)
        idx = np.flatnonzero(hit[k::K]) * K + k
        if idx.size == 0:
            continue
        at = t[idx]
        if gpu is not None:
            h, _, g, steps, _ = _trace(skargs, depth_max, options, pixels[idx // K], W,
                                       offsets[k:k + 1], (at.copy(), at.copy()), _ANY_DISTANCE,
                                       gpu)
        else:
            h, g, steps = _gradients(skargs, depth_max, pixels[idx // K], W, offsets[k:k + 1],
                                     at)
        evals += int(steps.sum())
        grad[idx[h]] = g[h]
    return evals


def _gradients(kargs, depth_max, pixels, W, offset, at):
    """The field's gradient at depth ``at (m,)`` of the ray through ``pixels (m,)`` (flat
    indices) shifted by ``offset (1, 2)``, where a march from ``at`` to ``at`` would take it
    (:func:`tracer.rendering.march.gradient_tasks`): ``hit (m,), grad (m, 3), steps (m,)``."""
    tree, roots, params, mode, tol, cam, lo, hi, eps, max_steps = kargs
    m = pixels.size
    hit = np.zeros(m, dtype=np.bool_)
    grad = np.zeros((m, 3))
    steps = np.zeros(m, dtype=np.int64)
    rows, cols = np.divmod(pixels.astype(np.int64), W)
    ray = MarchArgs(roots, params, mode, tol, cam, lo, hi, eps, max_steps)
    samples = SampleRays(rows, cols, np.ascontiguousarray(offset, dtype=np.float64),
                         float(_ANY_DISTANCE), float(SAMPLE_NEWTON_COS))
    at = np.ascontiguousarray(at, dtype=np.float64)
    ntasks = parallel_tasks(m)
    wait_ahead("normals")   # a child compiling this kernel (compile_ahead) is done with it
    run_tasks(lambda a, b: march.gradient_tasks(tree, ray, samples, at, depth_max,
                                                (hit, grad, steps), (ntasks, a, b)), ntasks)
    return hit, grad, steps


def _clip01(c):
    return np.clip(c, 0.0, 1.0)


def _norm3(v):
    """The lengths ``(...)`` of the vectors ``v (..., 3)``: ``np.linalg.norm(v, axis=-1)``
    bit for bit (the same sum, in the same order), a third of its time (no temporary of
    squares, no reduction along a short axis)."""
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    return np.sqrt(x * x + y * y + z * z)


def _dot3(u, v):
    """Row-wise dot products of ``u, v (n, 3)``: ``(u * v).sum(axis=1)`` bit for bit (the same
    sum, in the same order), without its reduction along a short axis."""
    return u[:, 0] * v[:, 0] + u[:, 1] * v[:, 1] + u[:, 2] * v[:, 2]


def _unit(v):
    """``v (..., 3)`` divided by its lengths; 0 where the length is not > 0 (zero or NaN).
    Large arrays in chunks over the render's threads (:func:`_unit_of`)."""
    flat = v.reshape(-1, 3)
    if flat.shape[0] <= CHUNK:
        return _unit_of(v)
    out = np.empty(flat.shape)

    def chunk(a, b):
        out[a:b] = _unit_of(flat[a:b])
    in_chunks(chunk, flat.shape[0])
    return out.reshape(v.shape)


def _unit_of(v):
    """:func:`_unit` in one piece."""
    n = _norm3(v)
    zero = ~(n > 0)
    out = v / np.where(zero, 1.0, n)[..., None]
    if zero.any():
        out[zero] = 0.0
    return out


def _blend_normals(corners, normals, key, depth, my_key, my_depth):
    """Bilinear normals from centre pixels: ``corners``, a list of ``(j (n,) flat pixel or -1,
    w (n,))``; ``normals (H W, 3)`` unit, ``key``/``depth (H W,)`` of those pixels. Returns
    ``(n (n, 3) unit, ok (n,) bool)``; ``ok`` where every corner of weight > 0 sees the same
    object (``my_key``) at a depth within :data:`FILL_DEPTH` of ``my_depth`` and its normal
    lies within ``acos(SHADE_FILL_COS)`` of the blend (an interpolation, never across an
    edge, a crease or a fold)."""
    n = my_key.size
    acc = np.zeros((n, 3))
    ok = np.ones(n, dtype=bool)
    for j, w in corners:
        used = w > 0
        jj = np.where(j >= 0, j, 0)
        ok &= ~used | ((j >= 0) & (key[jj] == my_key)
                       & (np.abs(depth[jj] - my_depth) <= FILL_DEPTH * my_depth))
        acc += np.where(used, w, 0.0)[:, None] * normals[jj]
    m = _unit(acc)
    for j, w in corners:
        jj = np.where(j >= 0, j, 0)
        ok &= (w <= 0) | (_dot3(normals[jj], m) >= SHADE_FILL_COS)
    return m, ok


def _centre_shading_normals(skargs, depth_max, options, shape, hit, t, grad, objs,
                            gpu=None):
    """:func:`_shading_normals` of the centre samples ``(H W,)`` (``grad (H W, 3)`` written
    in place, as unit normals where interpolated): computed at every :data:`SHADE_STRIDE`-th
    pixel of every :data:`SHADE_STRIDE`-th row, interpolated bilinearly in between where the
    four around agree (:func:`_blend_normals`), computed where they do not. The shading field
    is smooth, so its normals interpolate; the render's own do not (they jump). Returns the
    distance evaluations made."""
    H, W = shape
    s = SHADE_STRIDE
    on_grid = np.zeros((H, W), dtype=bool)
    on_grid[::s, ::s] = True
    coarse = hit & on_grid.ravel()
    cpix = np.flatnonzero(coarse)
    g = grad[cpix]
    evals = _shading_normals(skargs, depth_max, options, cpix, W, np.zeros((1, 2)),
                             np.ones(cpix.size, dtype=bool), t[cpix], g, gpu)
    grad[cpix] = g
    rest = np.flatnonzero(hit & ~coarse)
    if rest.size:
        key = np.where(hit, objs, -1)
        units = _unit(grad)
        n = np.empty((rest.size, 3))
        ok = np.empty(rest.size, dtype=bool)

        def chunk(a, b):                    # each pixel on its own
            rr, cc = np.divmod(rest[a:b], W)
            r0, c0 = (rr // s) * s, (cc // s) * s
            fr, fc = (rr - r0) / s, (cc - c0) / s
            corners = []
            for dr, dc, w in ((0, 0, (1 - fr) * (1 - fc)), (0, s, (1 - fr) * fc),
                              (s, 0, fr * (1 - fc)), (s, s, fr * fc)):
                ri, ci = r0 + dr, c0 + dc
                j = np.where((ri < H) & (ci < W), ri * W + np.minimum(ci, W - 1), -1)
                corners.append((np.where((j >= 0) & coarse[np.maximum(j, 0)], j, -1), w))
            n[a:b], ok[a:b] = _blend_normals(corners, units, key, t, key[rest[a:b]],
                                             t[rest[a:b]])
        in_chunks(chunk, rest.size)
        grad[rest[ok]] = n[ok]
        todo = rest[~ok]
        g = grad[todo]
        evals += _shading_normals(skargs, depth_max, options, todo, W, np.zeros((1, 2)),
                                  np.ones(todo.size, dtype=bool), t[todo], g, gpu)
        grad[todo] = g
    return evals


def _sample_shading_normals(skargs, depth_max, options, pixels, W, offsets, position, centre,
                            hit, t, grad, objs, gpu=None):
    """:func:`_shading_normals` of extra samples (arguments as there; ``position = (rows,
    cols)`` their fractional image positions, ``centre = (H, W, key, depth, normals)`` of
    the centre samples, normals unit and final): bilinear from the four centre pixels
    around a sample where they agree (:func:`_blend_normals`), computed elsewhere."""
    H, W_, key, depth, normals = centre
    rows, cols = position
    r0 = np.floor(rows).astype(np.int64)
    c0 = np.floor(cols).astype(np.int64)
    fr, fc = rows - r0, cols - c0
    corners = []
    for dr, dc, w in ((0, 0, (1 - fr) * (1 - fc)), (0, 1, (1 - fr) * fc),
                      (1, 0, fr * (1 - fc)), (1, 1, fr * fc)):
        ri, ci = r0 + dr, c0 + dc
        inside = (ri >= 0) & (ri < H) & (ci >= 0) & (ci < W_)
        corners.append((np.where(inside, ri * W_ + ci, -1), w))
    my_key = np.where(hit, objs, -2)
    n, ok = _blend_normals(corners, normals, key, depth, my_key, np.where(hit, t, 0.0))
    ok &= hit
    grad[ok] = n[ok]
    return _shading_normals(skargs, depth_max, options, pixels, W, offsets, hit & ~ok, t, grad,
                            gpu)


def form_image(scene, camera, arrays, kargs, options, centre, gpu=None, progress=None):
    """Shade the centre samples, add ``scene.film.samples - 1`` more per pixel (all pixels, or
    the adaptive selection when ``scene.film.adaptive``), and average.

    ``kargs``: :class:`tracer.rendering.frame.RayArgs`, the march kernels' leading arguments;
    ``options``: :class:`tracer.rendering.frame.TraceOptions`;
    ``centre = (hit (H, W), t (H, W), grad (H, W, 3), objs (H, W))`` (``objs``: the object each hit
    shows, as the march found it). Returns
    ``(rgb (H, W, 3) uint8, alpha (H, W) float32, spp (H, W) int32, info dict)``; ``info``
    holds the centre samples' ``shadow``, ``ao``, ``object`` and ``ground`` maps (lit only)
    and the ``rays``, ``light_queries`` and ``shading_queries`` counts.

    Lit renders in smooth mode whose beta exceeds :data:`BETA_SHADE` shade every hit with the
    normal of the field at that beta (``_shading_normals``), and write the centre's into
    ``centre``'s ``grad`` (in place: the render's normals are those the image is lit with).
    ``gpu``: :mod:`tracer.rendering.gpu_render` (passed in by it: this module does not import
    it) to trace the samples' and the light's rays on the GPU (the same per-ray functions);
    None on the CPU. Everything else runs on the host either way. ``progress``: called with
    the share of the film's work done (0 to 1) after each of its passes, and 1 at the end."""
    film = scene.film
    H, W, samples, adaptive = film.height, film.width, film.samples, film.adaptive
    hit0, t0, grad0, objs0 = (np.asarray(a) for a in centre)
    hit0, t0, objs0 = hit0.ravel(), t0.ravel(), objs0.ravel()
    grad0 = grad0.reshape(-1, 3)        # a view: written in place
    rays0 = _primary_rays(camera)
    skargs = _shading_args(kargs) if scene.film.shading == "lit" else None
    shade_evals = 0
    if skargs is not None:
        shade_evals += _centre_shading_normals(skargs, arrays.depth_max, options, (H, W), hit0,
                                               t0, grad0, objs0, gpu)
        centre_normals = (H, W, np.where(hit0, objs0, -1), t0, _unit(grad0))
    tell = progress or (lambda fraction: None)
    tell(0.1 if skargs is not None else 0.0)
    wait_ahead("light")     # a child compiling the light's kernels is done with them
    shader = _Shader(scene, camera, arrays, kargs, gpu)
    colour0, alpha0, rec0 = shader.shade(hit0, t0, grad0, rays0, grid=(H, W), objs=objs0)
    tell(0.5 if samples > 1 else 0.9)
    acc = colour0 * alpha0[:, None]
    acc_a = alpha0.copy()
    spp = np.ones(H * W, dtype=np.int32)
    offsets = sample_offsets(samples)
    rays = 0
    work = [0]
    # the pixels' cone bounds (march.sample_tasks), kept from one pass to the next
    cone_lo = np.full(H * W, np.nan)
    cone_hi = np.full(H * W, np.nan)

    def add(pixels, ks):
        nonlocal rays, shade_evals
        if pixels.size == 0 or len(ks) == 0:
            return None
        ks = np.asarray(ks)
        pix = np.repeat(pixels, len(ks))
        kk = np.tile(ks, pixels.size)
        r = (pix // W).astype(np.float64) + offsets[kk, 0]
        c = (pix % W).astype(np.float64) + offsets[kk, 1]
        rays_k = sample_rays(kargs.cam, r, c)
        bounds = (cone_lo[pixels], cone_hi[pixels])
        hit, t, grad, st, obj = _trace(kargs, arrays.depth_max, options, pixels, W, offsets[ks],
                                       bounds, gpu=gpu)
        cone_lo[pixels], cone_hi[pixels] = bounds
        if skargs is not None:
            shade_evals += _sample_shading_normals(skargs, arrays.depth_max, options, pixels,
                                                   W, offsets[ks], (r, c), centre_normals,
                                                   hit, t, grad, obj, gpu)
        rays += pix.size
        work[0] += int(st.sum())
        reuse = None
        if shader.lit:
            # a sample's light: interpolated from the centre samples around it (that see
            # what it sees), else its own
            reuse = {"position": (r, c), "centre": rec0, "shape": (H, W)}
        col, a, rec = shader.shade(hit, t, grad, rays_k, reuse, objs=obj)
        np.add.at(acc, pix, col * a[:, None])
        np.add.at(acc_a, pix, a)
        np.add.at(spp, pix, 1)
        return pix, col, rec

    if samples > 1 and not adaptive:
        add(np.arange(H * W), range(1, samples))
    elif samples > 1:
        shown0 = shader.encode(colour0)
        flags, edges = _neighbour_flags(shown0, rec0, (H, W))
        # stages: every flagged pixel gets ADAPTIVE_FIRST samples; those whose samples
        # disagree (or that lie on a silhouette or an object border) ADAPTIVE_SECOND; those
        # whose samples still disagree all of them
        pix = np.flatnonzero(flags)
        disp = shown0[pix][:, None]
        keys = _sample_keys(rec0)[pix][:, None]
        done = 1
        for stage, n in enumerate((ADAPTIVE_FIRST, ADAPTIVE_SECOND, samples)):
            n = min(n, samples)
            if n <= done or pix.size == 0:
                continue
            out = add(pix, range(done, n))
            tell(0.5 + 0.15 * (stage + 1))
            m = n - done
            disp = np.concatenate([disp, shader.encode(out[1]).reshape(pix.size, m, 3)], axis=1)
            keys = np.concatenate([keys, _sample_keys(out[2]).reshape(pix.size, m)], axis=1)
            done = n
            if done >= samples:
                break
            # what the samples saw: an object (index), or nothing (-1)
            spread = (keys.min(axis=1) != keys.max(axis=1))
            if stage == 0:
                spread |= (disp.max(axis=1) - disp.min(axis=1)).max(axis=1) > SAMPLE_SPREAD
                # a silhouette or an object border: 4 samples that happen to agree do not
                # say how much of the tent footprint is covered
                spread |= edges[pix]
            pix, disp, keys = pix[spread], disp[spread], keys[spread]

    rgb, cover = _composite(shader, acc, acc_a, spp)
    rgb = rgb.reshape(H, W, 3)
    tell(1.0)
    info = {"rays": int(H * W + rays), "sample_steps": work[0], "shading_queries": shade_evals}
    if shader.lit:
        info.update(shadow=rec0["shadow"].reshape(H, W), ao=rec0["ao"].reshape(H, W),
                    object=rec0["obj"].reshape(H, W), ground=rec0["on_ground"].reshape(H, W),
                    light_queries=shader.queries, light_leaves=shader.leaves)
    return rgb, cover.reshape(H, W).astype(np.float32), spp.reshape(H, W), info


def _primary_rays(camera):
    """The camera's primary rays ``(origins, dirs)``: ``dirs (H W, 3)``
    (:func:`tracer.rendering.camera.primary_rays`), in bands of rows over the render's threads,
    and ``origins`` (:func:`tracer.rendering.camera.ray_origins`: the eye ``(3,)``, or ``(H W,
    3)`` for parallel rays)."""
    dirs = np.empty((camera.height, camera.width, 3))

    def rays(r0, r1):
        dirs[r0:r1] = primary_rays(camera, rows=(r0, r1))
    in_bands(rays, camera.height)
    origins = ray_origins(camera)
    return (origins if origins.ndim == 1 else origins.reshape(-1, 3)), dirs.reshape(-1, 3)


def _at(origins, index):
    """The rays' origins at ``index`` (a slice or indices): ``origins`` itself when all rays
    share one (a perspective camera's eye, ``(3,)``), else its rows."""
    return origins if origins.ndim == 1 else origins[index]


def _composite(shader, acc, acc_a, spp):
    """``(rgb (n, 3) uint8, cover (n,))`` of pixels from their sums over samples: colours
    ``acc`` (premultiplied), alphas ``acc_a`` and sample counts ``spp``, over the background
    unless transparent; each pixel on its own, in chunks over the render's threads."""
    n = len(spp)
    cover = np.empty(n)
    rgb = np.empty((n, 3), dtype=np.uint8)

    def chunk(a, b):
        cover[a:b] = acc_a[a:b] / spp[a:b]
        if shader.transparent:
            colour = np.where(acc_a[a:b, None] > 0,
                              acc[a:b] / np.maximum(acc_a[a:b], 1e-300)[:, None], 0.0)
        else:
            mean = acc[a:b] / spp[a:b, None]       # premultiplied
            colour = mean + (1.0 - cover[a:b])[:, None] * shader.bg
        rgb[a:b] = np.round(255.0 * shader.encoder(colour)).astype(np.uint8)
    in_chunks(chunk, n)
    return rgb, cover
