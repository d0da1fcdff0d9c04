"""Image regression tests: golden renders of every shipped scene, checks of the checkers, and the
sphere tracer against an independent pipeline (pyvista marching cubes) and an analytic sphere.

Golden images
-------------
``tests/baseline/<scene>-<mode>.png``: every ``scenes/*.json`` rendered at 64 x 64 pixels in
``smooth`` and in ``exact`` mode (the scene's own shading, camera and parameters otherwise),
compared by the ``image_regression`` fixture that the package gives every test suite
(:mod:`tracer.pytest_plugin`; our ``pyproject.toml`` leaves its baseline folder at the default,
``tests/baseline``). A render passes when the mean absolute error is at most ``tol`` (0-255
units) and at most ``max_fraction`` of the pixels differ by more than ``threshold`` in some
channel (:class:`Tolerance`; per-case overrides in ``TOLERANCES``). On failure the render, the
baseline and their difference heat map are written to ``.image-regression/<case>/``
(git-ignored) and named in the assertion; ``--image-report DIR`` writes a page of every
comparison.

Baselines are never written implicitly. To create or update them (after checking that the
change is intended)::

    python -m pytest tests/tracer/rendering/test_render_golden.py --regen-baselines                  # all
    python -m pytest tests/tracer/rendering/test_render_golden.py --regen-baselines -k torus-smooth  # some

The pyvista tests are skipped, with the reason, where VTK cannot render off-screen.
"""

import dataclasses
import functools
import sys
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest

TESTS = Path(__file__).resolve().parents[2]
ROOT = TESTS.parent

from tracer.image import load_png, save_png
from tracer.checks.imagediff import check_images

SCENES = sorted((ROOT / "scenes").glob("*.json"))
MODES = ("smooth", "exact")
SIZE = 64
BASELINE_DIR = TESTS / "baseline"
REGEN_COMMAND = "python -m pytest tests/tracer/rendering/test_render_golden.py --regen-baselines"


class Tolerance(NamedTuple):
    """Pass criteria of a golden-image comparison (see :func:`tracer.checks.imagediff.check_images`).

    The default allows a handful of silhouette pixels to flip (a hit / miss decision at a
    grazing ray can change with the CPU's floating point, e.g. FMA contraction) but not a
    shifted camera or a changed alpha, which move the whole silhouette
    (``test_shifted_camera_fails``, ``test_changed_alpha_fails``).
    """

    tol: float = 1.0            # mean abs error, 0-255 units
    threshold: int = 16         # per-pixel largest channel difference counted as "over"
    max_fraction: float = 0.005  # of the pixels over the threshold (20 of 64 x 64)


DEFAULT_TOLERANCE = Tolerance()
#: per-case overrides, keyed by case name ("<scene>-<mode>")
TOLERANCES = {}


# --------------------------------------------------------------------------- helpers
def case_name(scene_path, mode):
    """``"<scene stem>-<mode>"``: the baseline's file stem and the test id."""
    return f"{Path(scene_path).stem}-{mode}"


CASES = [(p, m) for p in SCENES for m in MODES]
CASE_IDS = [case_name(p, m) for p, m in CASES]


@functools.lru_cache(maxsize=None)
def load_small(scene_path, size=SIZE):
    """The scene at ``size x size`` pixels (loaded and its BVHs built once per session)."""
    from tracer.scenes.scene import load_scene

    return load_scene(str(scene_path), {"width": size, "height": size})


def render_case(scene_path, mode, size=SIZE):
    """The golden render of a case: ``(size, size, 3)`` uint8."""
    from tracer.rendering.renderer import render

    scene = dataclasses.replace(load_small(scene_path, size), mode=mode)
    return render(scene).rgb


# --------------------------------------------------------------------------- golden images
@pytest.mark.parametrize("scene_path,mode", CASES, ids=CASE_IDS)
def test_golden_image(scene_path, mode, image_regression):
    name = case_name(scene_path, mode)
    rgb = render_case(scene_path, mode)
    assert rgb.shape == (SIZE, SIZE, 3) and rgb.dtype == np.uint8
    image_regression.check(rgb, name=name, **TOLERANCES.get(name, DEFAULT_TOLERANCE)._asdict())


@pytest.mark.parametrize("scene_path", SCENES, ids=[p.stem for p in SCENES])
def test_every_scene_renders_lit_from_the_command_line(scene_path, tmp_path):
    """The gallery's command (docs/guide/rendering.md: every scene, lit, adaptive samples),
    in-process at 24 x 24 (the page's own command, run as a test of that page, would start 14
    interpreters): it exits 0 and writes an image with shading (more than 8 colours; a render
    that failed to hit anything is the background and the ground's fade)."""
    from tracer.cli import main

    out = tmp_path / f"{scene_path.stem}.png"
    rc = main(["render", str(scene_path), "-o", str(out), "--size", "24", "24", "--shading",
               "lit", "--samples", "4", "--adaptive", "--overwrite", "-q"])
    assert rc == 0 and out.is_file()
    rgb = load_png(out)
    assert rgb.shape[:2] == (24, 24)
    colours = np.unique(rgb.reshape(-1, rgb.shape[-1]), axis=0)
    assert len(colours) > 8, scene_path.stem     # shading varies over the object


def test_every_scene_has_baselines(request):
    assert SCENES, "no scenes/*.json found"
    if request.config.getoption("--regen-baselines"):
        pytest.skip("--regen-baselines: the baselines are being written")
    missing = [n for n in CASE_IDS if not (BASELINE_DIR / f"{n}.png").is_file()]
    assert not missing, (f"{len(missing)} baseline(s) missing ({', '.join(missing)}); create "
                         f"them with `{REGEN_COMMAND}`")
    stale = sorted(p.stem for p in BASELINE_DIR.glob("*.png") if p.stem not in CASE_IDS)
    assert not stale, f"baselines without a scene: {', '.join(stale)} (delete them)"


def test_the_fixture_reads_our_baselines(pytestconfig):
    """Our baselines are where the fixture looks: the ini option's default, from the rootdir."""
    folder = Path(str(pytestconfig.rootpath)) / pytestconfig.getini("image_baseline_dir")
    assert folder.resolve() == BASELINE_DIR.resolve()


# --------------------------------------------------------------------------- the criteria
CHECK_SCENE = ROOT / "scenes" / "bunny_triangles.json"


@pytest.fixture(scope="module")
def reference():
    """The unperturbed render of the checkers' scene and its scene object."""
    from tracer.rendering.renderer import render

    scene = load_small(CHECK_SCENE)
    return scene, render(scene).rgb


def _verdict(image, reference_rgb):
    return check_images(image, reference_rgb, **DEFAULT_TOLERANCE._asdict())


def test_identical_render_passes(reference):
    from tracer.rendering.renderer import render

    scene, rgb = reference
    verdict = _verdict(render(scene).rgb, rgb)   # deterministic, whatever the thread count
    assert verdict.passed, verdict.summary()
    assert verdict.diff.mean_abs_error == 0.0 and verdict.diff.max_abs_error == 0


def test_shifted_camera_fails(reference):
    """Moving the camera sideways by 1.5 pixels' worth must be caught."""
    from tracer.rendering.frame import camera_of
    from tracer.rendering.renderer import render

    scene, rgb = reference
    cam = camera_of(scene)
    dist = float(np.linalg.norm(scene.camera_dest - scene.camera_origin))
    shift = 1.5 * dist / scene.width * cam.horizontal   # the image plane spans dist at dist
    moved = dataclasses.replace(scene, camera_origin=scene.camera_origin + shift,
                                camera_dest=scene.camera_dest + shift)
    verdict = _verdict(render(moved).rgb, rgb)
    assert not verdict.passed
    assert verdict.diff.fraction_over > 3 * DEFAULT_TOLERANCE.max_fraction


def test_changed_alpha_fails(reference):
    """A 20 % larger alpha (thinner blur) must be caught."""
    from tracer.rendering.renderer import render

    scene, rgb = reference
    objs = [dataclasses.replace(o, alpha=1.2 * o.alpha) for o in scene.objects]
    verdict = _verdict(render(dataclasses.replace(scene, objects=objs)).rgb, rgb)
    assert not verdict.passed
    assert verdict.diff.fraction_over > 3 * DEFAULT_TOLERANCE.max_fraction


# --------------------------------------------------------------------------- tracer diff CLI
@pytest.fixture
def pngs(tmp_path):
    rng = np.random.default_rng(7)
    a = rng.integers(0, 256, size=(20, 30, 3), dtype=np.uint8)
    b = a.copy()
    b[:5] = 255 - b[:5]                          # a quarter of the rows inverted
    paths = {"a": tmp_path / "a.png", "b": tmp_path / "b.png", "small": tmp_path / "s.png"}
    save_png(paths["a"], a)
    save_png(paths["b"], b)
    save_png(paths["small"], a[:10])
    return paths


def test_diff_cli_exit_codes(pngs, tmp_path, capsys):
    from tracer.cli import main

    a, b = str(pngs["a"]), str(pngs["b"])
    assert main(["diff", a, a]) == 0
    assert "PASS" in capsys.readouterr().out
    out = tmp_path / "d.png"
    assert main(["diff", a, b, "-o", str(out)]) == 1
    assert "FAIL" in capsys.readouterr().out and out.is_file()
    assert load_png(out).shape == (20, 30, 3)
    assert main(["diff", a, b, "--tol", "1000"]) == 0                    # mean only
    assert main(["diff", a, b, "--tol", "1000", "--max-fraction", "0.1"]) == 1
    capsys.readouterr()
    assert main(["diff", a, str(tmp_path / "missing.png")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and "missing.png" in err[0]
    assert main(["diff", a, str(pngs["small"])]) == 2
    assert "shapes differ" in capsys.readouterr().err
    assert main(["diff", a, b, "-o", str(out)]) == 2                     # no --overwrite
    assert "exists" in capsys.readouterr().err


def test_diff_cli_as_a_process(pngs, tmp_path):
    import subprocess

    def status(*args):
        return subprocess.run([sys.executable, "-m", "tracer", "diff", *map(str, args)],
                              cwd=ROOT, capture_output=True, text=True).returncode

    assert status(pngs["a"], pngs["a"]) == 0
    assert status(pngs["a"], pngs["b"]) == 1
    assert status(pngs["a"], tmp_path / "missing.png") == 2


# --------------------------------------------------------------------------- pyvista
@pytest.fixture(scope="module")
def compare_mod():
    """``tracer.checks.compare`` (needs pyvista for the marching cubes)."""
    pytest.importorskip("pyvista")
    from tracer.checks import compare

    return compare


@pytest.fixture(scope="module")
def compare_render(compare_mod):
    """``tracer.checks.compare`` where VTK can render off-screen (skipped, with the reason, if not)."""
    problem = compare_mod.offscreen_problem()
    if problem is not None:
        pytest.skip(f"VTK cannot render off-screen here: {problem}")
    return compare_mod


#: (scene, smallest IoU, largest mean normal angle in degrees, largest mean depth error / diagonal)
#: at a 64^3 grid and 64 x 64 pixels. Measured: bunny_points 0.996 / 0.5 / 6.9e-4, two_objects
#: 0.994 / 1.0 / 9.3e-4, trefoil 0.985 / 2.4 / 3.8e-3, capillary_exact 0.968 / 10.0 / 2.1e-3.
#: The bounds leave room for the marching-cubes rim of a pixel or two (thin tubes: trefoil,
#: capillaries; see the tracer.checks.compare docstring) but not for a camera or field mismatch (a
#: half-pixel camera shift alone costs more). The exact-offset surface of the capillary
#: network is a union of capsules with concave creases wherever two tubes meet; Gouraud-
#: interpolated vertex normals straddle those creases, hence its larger normal error.
PYVISTA_CASES = [("bunny_points", 0.97, 3.0, 3e-3), ("two_objects", 0.97, 3.0, 3e-3),
                 ("trefoil", 0.95, 6.0, 1e-2), ("capillary_exact", 0.93, 15.0, 6e-3)]


@pytest.mark.parametrize("name,min_iou,max_angle,max_depth", PYVISTA_CASES,
                         ids=[c[0] for c in PYVISTA_CASES])
@pytest.mark.slow
def test_pyvista_isosurface_matches_tracer(compare_render, name, min_iou, max_angle, max_depth):
    scene = load_small(ROOT / "scenes" / f"{name}.json")
    m = compare_render.compare_scene(scene, grid=64).metrics
    assert m["both_hit"] > 100, m
    assert m["iou"] >= min_iou, m
    assert m["normal_angle_mean_deg"] <= max_angle, m
    assert m["depth_error_rel_diag"] <= max_depth, m


def test_scene_field_matches_the_tracer_kernel(compare_mod):
    """The grid sampler evaluates exactly the function the tracer marches."""
    from tracer.rendering import march
    from tracer.rendering.frame import scene_arrays

    rng = np.random.default_rng(3)
    for name in ("two_objects", "capillary_exact", "bunny_points"):
        scene = load_small(ROOT / "scenes" / f"{name}.json")
        tree, roots, params, mode, lo, hi, depth_max, tol = scene_arrays(scene)
        P = lo + (hi - lo) * rng.random((40, 3))
        d, _ = compare_mod.scene_field(scene, P)
        ref = [march.distance_at((tree, roots, params, mode, tol), *map(float, p), depth_max)
               for p in P]
        np.testing.assert_allclose(d, ref, rtol=1e-12, atol=1e-12 * scene.diagonal,
                                   err_msg=name)


def _sphere_cloud_scene(beta=0.5, size=64):
    """1500 Fibonacci points on the unit sphere at alpha 20: a closed, hollow, bumpy sphere."""
    from smoothdist import SmoothDistanceField
    from tracer.scenes.scene import scene_from_field

    field = SmoothDistanceField(fibonacci_sphere(1500))
    return scene_from_field(field, alpha=20.0, beta=beta, width=size, height=size,
                            camera=([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]))


@pytest.mark.parametrize("name", ["two_objects", "sphere_cloud"])
def test_pruned_grid_gives_the_same_surface(compare_mod, name):
    """Skipping provably-outside grid points does not change the marching-cubes surface (the
    hollow sphere checks the Barnes-Hut allowance of the certificate: far-field nodes are
    evaluated at their box distance, closer than their points)."""
    if name == "sphere_cloud":
        scene, n = _sphere_cloud_scene(), 36
    else:
        scene, n = load_small(ROOT / "scenes" / f"{name}.json"), 28
    full, _, _, ev_full = compare_mod.sample_grid(scene, n, prune=False)
    pruned, _, _, ev = compare_mod.sample_grid(scene, n, prune=True)
    assert ev_full == 1.0 and ev < 0.9
    np.testing.assert_array_equal(full > 0, pruned > 0)
    a = compare_mod.isosurface(scene, n, prune=True)
    b = compare_mod.isosurface(scene, n, prune=False)
    assert a.n_points > 0
    np.testing.assert_array_equal(np.asarray(a.points), np.asarray(b.points))
    np.testing.assert_array_equal(np.asarray(a.faces), np.asarray(b.faces))


def fibonacci_sphere(n):
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(1.0 - z * z)
    theta = np.pi * (1.0 + np.sqrt(5.0)) * i
    return np.stack([r * np.cos(theta), r * np.sin(theta), z], axis=1)


def test_sphere_point_cloud_matches_analytic_disc(compare_render):
    """1500 Fibonacci points on the unit sphere at alpha 20 close into a bumpy sphere of radius
    r_iso ~ 1.08 (the 'continuum' estimate: density 1500 / 4 pi, sum of exp(-alpha r) over
    the sphere = 1). Both pipelines' silhouettes must match the analytic disc of radius r_iso."""
    from tracer.rendering.camera import primary_rays
    from tracer.rendering.frame import camera_of
    from tracer.rendering.renderer import render

    alpha, beta = 20.0, 0.5           # beta as in the scenes (0 would take ~20 x longer)
    scene = _sphere_cloud_scene(beta=beta)
    field = scene.objects[0].field

    def dhat(Q):
        return field.smooth_distance(Q, alpha=alpha, beta=beta)[0]

    # closed: the whole unit sphere is inside the surface, and the centre is outside (hollow)
    assert np.all(dhat(fibonacci_sphere(997)) < 0)
    assert dhat([[0.0, 0, 0]])[0] > 0
    # r_iso along rays to the silhouette's rim (perpendicular to the view axis +z) by bisection
    phis = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    rim = np.stack([np.cos(phis), np.sin(phis), np.zeros_like(phis)], axis=1)
    lo_r, hi_r = np.full(len(rim), 1.0), np.full(len(rim), 2.0)
    for _ in range(50):
        mid = 0.5 * (lo_r + hi_r)
        inside = dhat(rim * mid[:, None]) <= 0
        lo_r = np.where(inside, mid, lo_r)
        hi_r = np.where(inside, hi_r, mid)
    radii = 0.5 * (lo_r + hi_r)
    r_iso = float(radii.mean())
    assert 1.05 < r_iso < 1.12 and radii.max() - radii.min() < 0.01 * r_iso

    trace = render(scene)
    cam = camera_of(scene)
    rays = primary_rays(cam)
    b = rays @ cam.origin
    disc = b * b - (cam.origin @ cam.origin - r_iso ** 2)
    analytic = disc >= 0
    t_true = -b - np.sqrt(np.where(analytic, disc, 0.0))

    result = compare_render.compare_scene(scene, grid=64, trace=trace)
    pv_hit = result.pyvista.hit

    def iou(a, c):
        return (a & c).sum() / (a | c).sum()

    assert analytic.sum() > 1500
    for label, mask in (("tracer", trace.hit), ("pyvista", pv_hit)):
        assert iou(mask, analytic) > 0.98, (label, iou(mask, analytic))
        assert (mask ^ analytic).sum() <= 30, (label, int((mask ^ analytic).sum()))
    # depth where the ray meets the surface at < 60 degrees from the normal (sqrt(disc) is
    # r_iso cos(incidence)): there dt <= 2 dr, and the bumps between points are ~0.005
    inner = analytic & trace.hit & pv_hit & (disc > 0.25 * r_iso ** 2)
    for label, t in (("tracer", trace.depth), ("pyvista", result.pyvista.depth)):
        err = np.abs(t[inner] - t_true[inner])
        assert err.max() < 0.02 and err.mean() < 0.005, (label, err.max(), err.mean())
    assert result.metrics["iou"] > 0.98 and result.metrics["normal_angle_p95_deg"] < 3.0


def test_compare_cli_writes_outputs(compare_render, tmp_path, capsys):
    import json

    from tracer.cli import main

    out = tmp_path / "cmp"
    scene = str(ROOT / "scenes" / "trefoil.json")
    assert main(["compare", scene, "-o", str(out), "--grid", "24", "--size", "32", "32"]) == 0
    assert "IoU" in capsys.readouterr().out
    m = json.loads((out / "metrics.json").read_text())
    for key in ("iou", "normal_angle_mean_deg", "normal_angle_p95_deg", "depth_error_rel_diag",
                "grid", "size", "seconds"):
        assert key in m
    assert m["grid"] == 24 and m["size"] == [32, 32]
    for f in ("tracer.png", "pyvista.png", "diff.png"):
        assert load_png(out / f).shape == (32, 32, 3)
    sbs = load_png(out / "side_by_side.png")  # titled panels + colour bar (test_from_mesh)
    assert sbs.ndim == 3 and sbs.shape[0] > 32 and sbs.shape[1] > 3 * 32
    assert main(["compare", scene, "-o", str(out), "--grid", "24", "--size", "32", "32"]) == 2
    assert "exists" in capsys.readouterr().err
