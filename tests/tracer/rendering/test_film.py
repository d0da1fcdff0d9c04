"""Anti-aliasing (:mod:`tracer.rendering.film`) against geometry with known answers.

The test surface is an exact sphere: one data point in exact-offset mode with ``offset = R``
has the distance ``|p - c| - R``, so whether a camera ray hits it is a quadratic's
discriminant. Every expected value here is computed from that in numpy, with the camera's
pixel-to-ray mapping written out again (and checked against
:func:`tracer.rendering.camera.ray_direction`):

* **coverage**: a pixel's alpha is the tent-filtered coverage of its footprint; the reference
  integrates the tent weight ``(1 - |x|)(1 - |y|)`` over ``[-1, 1]^2`` pixels around the
  pixel's own ray on a dense grid, each point inside or outside by the ray-sphere test. The
  error falls as samples are added and is small at 64;
* the sample offsets are tent-distributed and nested (the adaptive pass relies on it);
* alpha is exactly the fraction of the pixel's samples whose rays hit (0 and 1 exactly where
  none or all do), and a transparent render round-trips through its RGBA PNG;
* the image does not depend on the number of threads;
* adaptive sampling spends its rays on the silhouette and gets close to uniform sampling.
"""

from pathlib import Path

import numba
import numpy as np
import pytest

from smoothdist import SmoothDistanceField
from tracer.rendering import film
from tracer.rendering.camera import look_at, primary_rays, ray_direction
from tracer.rendering.film import sample_offsets
from tracer.rendering.frame import MAX_SAMPLES, camera_of, scene_arrays, trace_options
from tracer.rendering.renderer import ray_args, render
from tracer.scenes.scene import load_scene, scene_from_field

ROOT = Path(__file__).resolve().parents[3]

CENTRE = np.array([0.3, -0.2, 0.1])
RADIUS = 1.0
SIZE = 40


def sphere_scene(samples=1, adaptive=False, size=SIZE, **kw):
    """An exact sphere (radius RADIUS) seen whole, about 2/3 of the image wide, slightly off
    centre so that its silhouette crosses the pixel grid at every angle."""
    field = SmoothDistanceField(CENTRE[None, :])
    kw.setdefault("camera", (CENTRE + [0.4, 0.7, 3.2], CENTRE + [0.05, -0.03, 0.0], [0, 1, 0]))
    return scene_from_field(field, alpha=1.0, mode="exact", offset=RADIUS, width=size,
                            height=size, samples=samples, adaptive=adaptive, **kw)


# ----------------------------------------------------------------------------- the reference
def ray_dirs(cam, rows, cols):
    """Unit directions through fractional image positions, as the camera module defines
    them (``dx = sx (col / W - 0.5)``, ``dy = sy ((H - 1 - row) / H - 0.5)``)."""
    W, H = cam.width, cam.height
    sx, sy = (W / H, 1.0) if W >= H else (1.0, H / W)
    dx = (np.asarray(cols, float) / W - 0.5) * sx
    dy = ((H - 1.0 - np.asarray(rows, float)) / H - 0.5) * sy
    d = cam.forward + dx[..., None] * cam.horizontal + dy[..., None] * cam.vertical
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def miss_distance(cam, d, radius=RADIUS):
    """Distance from the sphere's centre to each ray's line, minus the radius (< 0: hit)."""
    oc = cam.origin - CENTRE
    b = d @ oc
    return np.sqrt(np.maximum(oc @ oc - b * b, 0.0)) - radius


def tent_coverage(cam, rows, cols, n, radius=RADIUS):
    """Tent-weighted fraction of each pixel's footprint whose rays hit the sphere (midpoint
    rule on an n x n grid over [-1, 1]^2 pixels)."""
    u = (np.arange(n) + 0.5) / n * 2.0 - 1.0
    du, dc = (a.ravel() for a in np.meshgrid(u, u, indexing="ij"))
    w = (1.0 - np.abs(du)) * (1.0 - np.abs(dc))
    return np.array([(w * (miss_distance(cam, ray_dirs(cam, r + du, c + dc), radius) < 0)).sum()
                     / w.sum() for r, c in zip(rows, cols)])


@pytest.fixture(scope="module")
def coverage():
    """``(camera, analytic coverage (SIZE, SIZE), silhouette mask)``."""
    from scipy.ndimage import binary_dilation

    cam = camera_of(sphere_scene())
    rr, cc = np.mgrid[0:SIZE, 0:SIZE]
    coarse = tent_coverage(cam, rr.ravel(), cc.ravel(), 8).reshape(SIZE, SIZE)
    # a pixel can be partly covered although its coarse grid saw one side only: refine a band
    band = binary_dilation((coarse > 0) & (coarse < 1))
    A = (coarse >= 1).astype(float)
    A[band] = tent_coverage(cam, rr[band], cc[band], 96)
    return cam, A, (A > 0) & (A < 1)


def test_the_reference_rays_are_the_cameras():
    cam = camera_of(sphere_scene(size=24))
    arr = cam.as_array()
    for r, c in [(0.0, 0.0), (3.25, 17.5), (-0.7, 23.9), (12.0, 12.0)]:
        np.testing.assert_allclose(ray_dirs(cam, r, c), ray_direction(arr, r, c), atol=1e-15)


# ----------------------------------------------------------------------------- offsets
def tent_cdf(x):
    return np.where(x < 0, 0.5 * (1 + x) ** 2, 1.0 - 0.5 * (1 - x) ** 2)


def test_sample_offsets_are_nested_and_tent_distributed():
    big = sample_offsets(4096)
    assert big.shape == (4096, 2)
    np.testing.assert_array_equal(big[0], [0.0, 0.0])     # sample 0: the pixel's own ray
    assert np.abs(big).max() <= 1.0
    for n in (1, 4, 16, 64):                               # every prefix is the smaller set
        np.testing.assert_array_equal(sample_offsets(n), big[:n])
    for axis in (0, 1):                                    # Kolmogorov-Smirnov vs the tent
        x = np.sort(big[:, axis])
        ks = np.abs(tent_cdf(x) - np.arange(1, x.size + 1) / x.size).max()
        assert ks < 0.005, ks
    # the tent's moments: E x = 0, E x^2 = 1/6; the axes independent (E xy = 0)
    assert abs(big.mean()) < 1e-3
    np.testing.assert_allclose((big ** 2).mean(axis=0), 1 / 6, atol=1e-3)
    assert abs((big[:, 0] * big[:, 1]).mean()) < 1e-3
    # the first 16 are spread out: no two closer than 0.15 pixel
    d = np.linalg.norm(big[:16, None] - big[None, :16], axis=2) + 9 * np.eye(16)
    assert d.min() > 0.15


# ----------------------------------------------------------------------------- coverage
def _errors(A, edge, counts, **kw):
    out = {}
    for n in counts:
        res = render(sphere_scene(n, transparent=True, **kw))
        assert res.samples.min() == res.samples.max() == n
        out[n] = res.alpha.astype(float) - A
    return out


def test_coverage_converges_to_the_tent_filtered_footprint(coverage, monkeypatch):
    """alpha -> the tent-filtered coverage: mean |error| over the silhouette pixels falls from
    4 to 16 to 64 samples (measured on 204 pixels, with the extra samples' hit threshold at
    the scene's eps: 0.135 with 1 sample, then 0.081 / 0.041 / 0.013, and 0.004 at 256, largest
    0.017, no bias). Pixels away from the silhouette are exactly 0 or 1."""
    cam, A, edge = coverage
    assert edge.sum() > 150
    monkeypatch.setattr(film, "EPS_PX", 0.0)       # hit threshold: the scene's eps
    err = _errors(A, edge, (1, 4, 16, 64, 256))
    mean = {n: np.abs(e[edge]).mean() for n, e in err.items()}
    assert mean[1] > 0.1                            # one sample: no anti-aliasing
    assert mean[16] < 0.7 * mean[4] and mean[64] < 0.5 * mean[16], mean
    assert mean[64] < 0.02 and np.abs(err[64][edge]).max() < 0.08, mean
    assert mean[256] < 0.007 and abs(err[256][edge].mean()) < 0.003, mean   # no bias
    for e in err.values():
        assert np.abs(e[~edge]).max() == 0.0


def test_coverage_with_the_default_sample_threshold(coverage):
    """The extra samples count a ray that passes within film.EPS_PX (0.1) pixel of the
    surface as a hit, which fattens the silhouette by up to that much: alpha converges to
    the coverage of a sphere grown by <= 0.1 pixel (measured: mean error 0.084 / 0.053 /
    0.037 at 4 / 16 / 64 samples and 0.037 at 256: a bias of +0.036 that more samples do not
    remove; growing the sphere by 0.1 pixel adds 0.043)."""
    cam, A, edge = coverage
    err = _errors(A, edge, (4, 16, 64, 256))
    mean = {n: np.abs(e[edge]).mean() for n, e in err.items()}
    assert mean[4] > mean[16] > mean[64] and mean[64] < 0.05, mean
    # the bias: never below the true coverage by more than the sampling error, and at most
    # the coverage gained by growing the silhouette by EPS_PX pixel at the sphere's depth
    depth = np.sqrt(np.sum((cam.origin - CENTRE) ** 2) - RADIUS ** 2)
    grow = film.EPS_PX * depth / SIZE
    rr, cc = np.nonzero(edge)
    A_grown = tent_coverage(cam, rr, cc, 48, RADIUS + grow)
    bias = err[256][edge].mean()
    assert 0.0 <= bias <= (A_grown - A[edge]).mean() + 0.005, (bias, (A_grown - A[edge]).mean())


# ----------------------------------------------------------------------------- alpha
def test_alpha_is_the_fraction_of_samples_that_hit(tmp_path):
    """Transparent, no ground: alpha == (samples whose ray hits) / N exactly, for every pixel
    none of whose samples misses the sphere by less than 0.15 pixel (the samples' hit
    threshold is at most film.EPS_PX = 0.1 pixel); so exactly 0 where no sample hits and
    exactly 1 where all do. The RGBA PNG holds the image and round(255 alpha)."""
    from tracer.image import load_png

    n = 16
    scene = sphere_scene(n, transparent=True, lighting={"ground": False}, shading="lit")
    res = render(scene)
    cam = res.camera
    off = sample_offsets(n)
    rr, cc = np.mgrid[0:SIZE, 0:SIZE]
    rows = rr[..., None] + off[:, 0]
    cols = cc[..., None] + off[:, 1]
    miss = miss_distance(cam, ray_dirs(cam, rows, cols))          # (H, W, n)
    pixel = np.sqrt(np.sum((cam.origin - CENTRE) ** 2) - RADIUS ** 2) / SIZE
    clear = ((miss < 0) | (miss > 0.15 * pixel)).all(axis=2)
    expected = (miss < 0).sum(axis=2) / n
    assert clear.mean() > 0.8
    mixed = clear & (expected > 0) & (expected < 1)
    assert mixed.sum() >= 10                    # partly covered pixels are checked too
    assert (clear & (expected == 0)).sum() > 500 and (clear & (expected == 1)).sum() > 300
    np.testing.assert_array_equal(res.alpha[clear], expected[clear].astype(np.float32))
    rgba = res.rgba
    np.testing.assert_array_equal(rgba[..., 3], np.round(255 * res.alpha).astype(np.uint8))
    path = res.save(tmp_path / "sphere.png")
    back = load_png(path, alpha=True)
    assert back.shape == (SIZE, SIZE, 4)
    np.testing.assert_array_equal(back, rgba)


# ----------------------------------------------------------------------------- threads
@pytest.mark.slow
@pytest.mark.parametrize("adaptive", [False, True], ids=["uniform", "adaptive"])
def test_images_do_not_depend_on_the_thread_count(adaptive, octopus):
    """A lit render with 8 samples of a real mesh (a deep BVH: the kernels' scratch stacks
    are in use) is the same with 1 and 2 threads, every image and AOV."""
    from tracer.scenes.from_mesh import mesh_scene

    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba has a single thread here")
    scene = mesh_scene(octopus, size=(32, 32), view="iso", alpha=150.0, alpha_u=300.0,
                       samples=8, adaptive=adaptive)              # lit, ground and shadows
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = render(scene)
        numba.set_num_threads(2)
        two = render(scene)
    finally:
        numba.set_num_threads(before)
    for name in ("rgb", "alpha", "samples", "hit", "depth", "normals"):
        np.testing.assert_array_equal(getattr(one, name), getattr(two, name), err_msg=name)
    assert one.aovs.keys() == two.aovs.keys()
    for key, value in one.aovs.items():
        np.testing.assert_array_equal(value, two.aovs[key], err_msg=key)
    assert one.hit.mean() > 0.1 and one.aovs["ground"].any() and (one.aovs["shadow"] < 0.5).any()
    assert one.samples.max() == 8 and (adaptive == (one.samples.min() == 1))


# ----------------------------------------------------------------------------- adaptive
def test_adaptive_sampling_spends_its_rays_on_the_silhouette():
    """Silhouette pixels get ADAPTIVE_SECOND (8) samples, and all 16 exactly where those 8
    saw both the sphere and the background (checked against a uniform 8-sample render, whose
    offsets are the same); the background keeps one."""
    from scipy.ndimage import maximum_filter, minimum_filter

    kw = dict(shading="lit", lighting={"ground": False})
    one = render(sphere_scene(1, **kw))
    uni8 = render(sphere_scene(8, **kw))
    uni = render(sphere_scene(16, **kw))
    ada = render(sphere_scene(16, True, **kw))
    assert (uni.samples == 16).all() and uni.aovs["rays"] == 16 * SIZE * SIZE
    assert ada.aovs["rays"] == ada.samples.sum()
    hit = one.hit
    silhouette = maximum_filter(hit, size=3) != minimum_filter(hit, size=3)
    background = ~maximum_filter(hit, size=5)
    assert silhouette.sum() > 100 and background.sum() > 500
    assert (ada.samples[silhouette] >= film.ADAPTIVE_SECOND).all()
    assert (ada.samples[background] == 1).all()
    assert (ada.samples == 1).mean() > 0.6
    # the pixels that went on to 16 are those whose first 8 samples disagree
    eight = ada.samples >= film.ADAPTIVE_SECOND
    mixed8 = (uni8.alpha > 0) & (uni8.alpha < 1)
    np.testing.assert_array_equal(ada.samples[eight] == 16, mixed8[eight])
    assert 20 < (ada.samples == 16).sum() < (ada.samples == 8).sum() + (ada.samples == 16).sum()
    # where both sampled a pixel alike they agree exactly (the same offsets)
    full = ada.samples == 16
    np.testing.assert_array_equal(ada.alpha[full], uni.alpha[full])
    at8 = ada.samples == 8
    np.testing.assert_array_equal(ada.alpha[at8], uni8.alpha[at8])

    # as close to a 256-sample reference as uniform 16 (measured: 0.68 against 0.72 in 0-255
    # units; one sample 2.0, uniform 8 0.86), with under 40 % of its rays
    ref = render(sphere_scene(256, **kw))

    def mae(a):
        return np.abs(a.rgb.astype(float) - ref.rgb.astype(float)).mean()

    assert mae(ada) <= mae(uni) < 0.5 * mae(one), (mae(ada), mae(uni), mae(one))
    assert ada.aovs["rays"] < 0.4 * uni.aovs["rays"], (ada.aovs["rays"], uni.aovs["rays"])


# ----------------------------------------------------------------------------- bad values
@pytest.mark.parametrize("bad", [0, -1, MAX_SAMPLES + 1, 2.5, True])
def test_bad_sample_counts_are_one_line_errors(bad):
    import tracer

    pts = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    with pytest.raises(ValueError, match="samples must") as info:
        tracer.render_mesh(pts, samples=bad, size=(8, 8))
    assert "\n" not in str(info.value)
    scene = sphere_scene(size=8)
    with pytest.raises(ValueError, match="samples must be an integer from 1 to") as info:
        render(scene, samples=bad)
    assert "\n" not in str(info.value)


# ----------------------------------------------------------------------------- light stride
def _fill_case(shadows, aos, keys=(0, 0, 0, 0), lit_side=None):
    """A 4 x 4 image with stride 3: coarse pixels at (0, 0), (0, 3), (3, 0), (3, 3) holding
    ``shadows`` / ``aos`` / ``keys``; pixel (1, 1) wanted (same key 0, depth, normal)."""
    H = W = 4
    n = H * W
    corners = [0, 3, 12, 15]
    coarse = np.zeros(n, dtype=bool)
    coarse[corners] = True
    key = np.zeros(n, dtype=np.int64)
    key[corners] = keys
    shadow = np.full(n, -1.0)
    ao = np.full(n, -1.0)
    shadow[corners] = shadows
    ao[corners] = aos
    want = np.zeros(n, dtype=bool)
    want[5] = True
    depth = np.ones(n)
    normals = np.tile([0.0, 0.0, 1.0], (n, 1))
    side = None
    if lit_side is not None:
        side = np.ones(n, dtype=bool)
        side[corners] = lit_side
    got = film._fill_light((H, W), want, coarse, key, depth, normals, shadow, ao, side)
    return got, shadow[5], ao[5]


def test_light_fill_takes_each_factor_where_its_neighbours_agree(monkeypatch):
    """_fill_light interpolates the shadow where the coarse neighbours' shadows agree and the
    occlusion where their occlusions do, each on its own (bilinear weights at (1, 1) of a
    stride-3 grid: 4/9, 2/9, 2/9, 1/9); a neighbour of another object does not count."""
    monkeypatch.setattr(film, "LIGHT_STRIDE", 3)
    w = np.array([4, 2, 2, 1]) / 9
    s, a = [0.9, 0.95, 1.0, 0.92], [0.5, 0.52, 0.55, 0.58]
    (got_s, got_a), sh, oc = _fill_case(s, a)
    assert got_s[5] and got_a[5] and got_s.sum() == got_a.sum() == 1
    assert sh == pytest.approx(w @ s) and oc == pytest.approx(w @ a)
    # a shadow edge among the neighbours: the occlusion is still filled, the shadow is not
    (got_s, got_a), sh, oc = _fill_case([0.0, 1.0, 1.0, 1.0], a)
    assert not got_s[5] and got_a[5] and sh == -1.0 and oc == pytest.approx(w @ a)
    # an occlusion crease: the other way round
    (got_s, got_a), sh, oc = _fill_case(s, [0.2, 0.9, 0.9, 0.9])
    assert got_s[5] and not got_a[5] and sh == pytest.approx(w @ s) and oc == -1.0
    # the disagreeing neighbour sees another object: it is left out, both are filled
    (got_s, got_a), sh, oc = _fill_case([0.0, 1.0, 1.0, 1.0], a, keys=(1, 0, 0, 0))
    assert got_s[5] and got_a[5] and sh == pytest.approx(1.0)
    assert oc == pytest.approx(w[1:] @ a[1:] / w[1:].sum())
    # no neighbour of the same object: nothing is filled
    (got_s, got_a), sh, oc = _fill_case(s, a, keys=(1, 1, 1, 1))
    assert not got_s.any() and not got_a.any()
    # agreeing neighbours in the row below only (the row above is another object: the ground
    # under an object that stands on it): they do not see what lies between, so nothing is
    # filled; the same in the column to the right only
    for keys in ((1, 1, 0, 0), (1, 0, 1, 0)):
        (got_s, got_a), sh, oc = _fill_case(s, a, keys=keys)
        assert not got_s.any() and not got_a.any(), keys


@pytest.mark.slow
def test_light_at_every_third_pixel_against_every_pixel(octopus, monkeypatch):
    """The lit render's light computed at every LIGHT_STRIDE-th pixel and filled in between
    stays close to the light computed at every pixel: the coarse pixels are the same, and
    few others differ (measured: 2.0 % of the shadows and 2.7 % of the occlusions by more
    than 0.05, 2.3 % of the pixels' colour by more than 8 of 255, on this 64 x 64 octopus)."""
    from tracer.scenes.from_mesh import mesh_scene

    scene = mesh_scene(octopus, size=(64, 64), view="iso", alpha=150.0, alpha_u=300.0)
    strided = render(scene)
    monkeypatch.setattr(film, "LIGHT_STRIDE", 1)
    full = render(scene)
    rr, cc = np.mgrid[0:64, 0:64]
    coarse = (rr % 3 == 0) & (cc % 3 == 0)
    for k, limit in (("shadow", 0.04), ("ao", 0.05)):
        a, b = strided.aovs[k], full.aovs[k]
        np.testing.assert_array_equal(a[coarse], b[coarse], err_msg=k)
        assert (np.abs(a - b) > 0.05).mean() <= limit, k
        assert (a < 0.5).any() if k == "shadow" else (a < 0.9).any()     # something to fill
    colour = np.abs(strided.rgb.astype(int) - full.rgb.astype(int)).max(axis=2)
    assert (colour > 8).mean() <= 0.04


@pytest.mark.slow
def test_contact_shadow_on_the_ground_is_not_filled_in_lit(monkeypatch):
    """The scanned lion stands on the ground: the ground pixels just below its base lie in
    its contact shadow, between a coarse row on the lion and a lit coarse row of ground.
    Filled from the ground row alone they came out lit, a dotted light line under the base
    (31 of the 10,949 ground pixels at 192 x 192, against the light computed at every
    pixel); now they are computed on their own."""
    scene = load_scene(ROOT / "scenes" / "lion_points.json",
                       {"width": 192, "height": 192, "shading": "lit", "samples": 1})
    strided = render(scene)
    monkeypatch.setattr(film, "LIGHT_STRIDE", 1)
    full = render(scene)
    ground = strided.aovs["ground"] & full.aovs["ground"]
    assert ground.sum() > 5000 and (full.aovs["shadow"][ground] < 0.5).sum() > 100
    wrong = np.abs(strided.aovs["shadow"] - full.aovs["shadow"])[ground] > 0.5
    assert wrong.sum() == 0
    # the rule that does it: without it, the dotted line is back
    monkeypatch.setattr(film, "LIGHT_STRIDE", 3)
    monkeypatch.setattr(film, "FILL_BETWEEN", False)
    before = render(scene)
    assert (np.abs(before.aovs["shadow"] - full.aovs["shadow"])[ground] > 0.5).sum() >= 10


def test_light_fill_takes_no_shadow_from_across_the_terminator(monkeypatch):
    """A coarse neighbour that faces away from the key light (its shadow 0 set, not traced)
    fills neither the shadow of a pixel that faces the light (the rest agree: filled from
    them) nor makes them disagree; its occlusion still counts (bilinear weights as above)."""
    monkeypatch.setattr(film, "LIGHT_STRIDE", 3)
    w = np.array([4, 2, 2, 1]) / 9
    s, a = [0.0, 1.0, 1.0, 0.96], [0.5, 0.52, 0.55, 0.58]
    (got_s, got_a), sh, oc = _fill_case(s, a, lit_side=(False, True, True, True))
    assert got_s[5] and got_a[5]
    assert sh == pytest.approx(w[1:] @ s[1:] / w[1:].sum()) and oc == pytest.approx(w @ a)
    # all four on the other side (all 0, agreeing): the pixel's shadow is traced on its own
    (got_s, got_a), sh, oc = _fill_case([0.0] * 4, a, lit_side=(False,) * 4)
    assert not got_s[5] and got_a[5] and sh == -1.0


def test_the_films_host_shortcuts_give_numpys_values_bit_for_bit():
    # the film's faster forms (issue 49: its host work) must not move a pixel: lengths as
    # np.linalg.norm's, unit vectors as the division they replace (0 for a zero or NaN
    # length), primary rays in bands as in one piece, and the sRGB encoding in bands
    rng = np.random.default_rng(3)
    v = rng.normal(size=(5000, 3)) * rng.lognormal(sigma=4.0, size=(5000, 1))
    v[:3] = 0.0
    v[3, 1] = np.nan
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    assert np.array_equal(film._norm3(v), n[:, 0], equal_nan=True)
    u = rng.normal(size=v.shape)
    assert np.array_equal(film._dot3(u, v), (u * v).sum(axis=1), equal_nan=True)
    old = np.where(n > 0, v / np.where(n > 0, n, 1.0), 0.0)
    assert np.array_equal(film._unit(v), old) and np.array_equal(
        film._unit(v.reshape(50, 100, 3)), old.reshape(50, 100, 3))
    cam = look_at([0.3, 0.2, 3.0], [0, 0, 0], [0, 1, 0], 37, 53)
    whole = primary_rays(cam)
    bands = np.concatenate([primary_rays(cam, rows=(a, b)) for a, b in ((0, 20), (20, 53))])
    assert np.array_equal(whole, bands)

    class Lit:
        encoder = staticmethod(film._lighting.linear_to_srgb)
    colour = rng.random((1000, 3)) * 1.3 - 0.1
    assert np.array_equal(film._Shader.encode(Lit(), colour),
                          film._lighting.linear_to_srgb(colour))


def test_neighbour_flags_in_bands_are_the_pairwise_comparison():
    # the adaptive pass's flags, computed band by band over the threads (each band against
    # its rows' 8 neighbours), against the direct form: every pair of neighbouring pixels
    # compared once, both flagged when they differ
    H, W = 67, 45
    y, x = np.mgrid[0:H, 0:W].astype(float)
    hit = (x - 22) ** 2 + (y - 33) ** 2 < 20 ** 2
    obj = np.where(hit, (x > 30).astype(int), -1)
    # a smooth shade with a step (a shadow's edge) across the disk
    colour = np.stack([0.3 + 0.002 * x, 0.4 + 0.5 * (y > 40), 0.5 + 0.001 * y], -1) * hit[..., None]
    colour = colour.reshape(-1, 3)
    record = {"hit": hit.ravel(), "obj": obj.ravel()}
    c, keys = colour.reshape(H, W, 3), [record["hit"].reshape(H, W), record["obj"].reshape(H, W)]
    flags, edges = np.zeros((H, W), bool), np.zeros((H, W), bool)
    for r in range(H):
        for q in range(W):
            for r2, q2 in ((r, q + 1), (r + 1, q - 1), (r + 1, q), (r + 1, q + 1)):
                if r2 < H and 0 <= q2 < W:
                    geo = any(k[r, q] != k[r2, q2] for k in keys)
                    diff = geo or np.abs(c[r, q] - c[r2, q2]).max() > film.COLOR_CONTRAST
                    flags[r, q] |= diff
                    flags[r2, q2] |= diff
                    edges[r, q] |= geo
                    edges[r2, q2] |= geo
    for threads in (1, 3):
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
        try:
            f, e = film._neighbour_flags(colour, record, (H, W))
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        assert np.array_equal(f, flags.ravel()) and np.array_equal(e, edges.ravel())
    assert 0 < flags.sum() < H * W and 0 < edges.sum() < flags.sum()


def _gradient_case(case):
    """``(scene, camera, arrays, kargs)`` of one distance path the shading normals take:
    ``one`` smooth object (its lean int-root path), the same with ``tol > 0`` (the march
    evaluates loosened first, then again), ``two`` objects (the second LogSumExp), two
    ``posed`` objects (rigid bodies), ``exact``-offset mode."""
    size = {"width": 24, "height": 20}
    poses = None
    if case in ("one", "tol"):
        scene = load_scene(ROOT / "scenes" / "trefoil.json",
                           dict(size, tol=1e-2) if case == "tol" else size)
    elif case in ("two", "posed"):
        scene = load_scene(ROOT / "scenes" / "two_objects.json", size)
        if case == "posed":
            R = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
            poses = [(R, np.array([0.1, 0.0, 0.2])), (np.eye(3), np.zeros(3))]
    else:
        scene = sphere_scene(size=24)
    camera = camera_of(scene)
    arrays = scene_arrays(scene, poses)
    return scene, camera, arrays, ray_args(scene, camera, arrays)


@pytest.mark.parametrize("case", ["one", "tol", "two", "posed", "exact"])
def test_the_shading_gradients_are_the_samples_march_bit_for_bit(case):
    # the lit film's shading normals (at BETA_SHADE) come from a kernel of the distance alone
    # (march.gradient_tasks, compiled in a fraction of the samples' kernel's time); they were
    # the samples' march from t to t with a threshold any distance meets. Same bits, same hits,
    # at the render's hit depths and at depths before, inside and beyond the scene's box
    scene, camera, arrays, kargs = _gradient_case(case)
    kargs = film._shading_args(kargs) or kargs
    options = trace_options(scene, arrays.lo, arrays.hi)
    W, H = camera.width, camera.height
    pixels = np.arange(W * H)
    offsets = film.sample_offsets(4)
    hit, t, _, _, _ = film._trace(kargs, arrays.depth_max, options, pixels, W, offsets)
    assert 0 < hit.sum() < hit.size
    rng = np.random.default_rng(5)
    far = float(np.linalg.norm(arrays.hi - arrays.lo)) + np.linalg.norm(camera.origin)
    for k in range(len(offsets)):
        at = np.where(hit[k::len(offsets)], t[k::len(offsets)], rng.uniform(0.0, 1.5 * far, W * H))
        old_h, _, old_g, _, _ = film._trace(kargs, arrays.depth_max, options, pixels, W,
                                            offsets[k:k + 1], (at.copy(), at.copy()),
                                            film._ANY_DISTANCE)
        new_h, new_g, steps = film._gradients(kargs, arrays.depth_max, pixels, W,
                                              offsets[k:k + 1], at)
        assert np.array_equal(new_h, old_h)
        assert np.array_equal(new_g[new_h], old_g[old_h])      # bit for bit
        assert old_h.any() and not old_h.all()                  # both kinds of ray met
        # one evaluation where the point lies in the march's box, none elsewhere; every hit
        # was evaluated
        assert set(np.unique(steps)) <= {0, 1} and (steps[new_h] == 1).all()
