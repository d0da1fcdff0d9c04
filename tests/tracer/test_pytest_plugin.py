"""``tracer.pytest_plugin``: the ``image_regression`` fixture a user's suite gets by installing
the package (pytest's ``pytest11`` entry point), run in a throwaway project with ``pytester``;
and a render's ``_repr_png_`` (notebook display)."""

import io

import numpy as np
import pytest

from smoothdist import _kernel_cache

pytest_plugins = ["pytester"]

#: the kernel cache this run loads from, read before ``pytester`` points HOME at its own folder:
#: a subprocess run there would look for the per-machine cache under that HOME, find it empty
#: and compile a first render's kernels afresh (19 s of CPU, for nothing this file tests)
KERNEL_CACHE = _kernel_cache.root()

USER_TEST = """
import numpy as np

def _image(level):
    img = np.full((16, 16, 3), 255, np.uint8)
    img[4:12, 4:12] = level
    return img

def test_square(image_regression):
    image_regression.check(_image({level}))
"""


def test_baselines_are_written_only_on_request(pytester):
    pytester.makepyfile(test_user=USER_TEST.format(level=40))
    res = pytester.runpytest()
    res.assert_outcomes(failed=1)
    res.stdout.fnmatch_lines(["*no baseline*--regen-baselines*"])
    assert not (pytester.path / "tests" / "baseline").exists()
    res = pytester.runpytest("--regen-baselines")
    res.assert_outcomes(passed=1)
    assert (pytester.path / "tests" / "baseline" / "test_square.png").is_file()
    pytester.runpytest().assert_outcomes(passed=1)


def test_a_changed_image_fails_and_writes_the_three_images(pytester):
    pytester.makepyfile(test_user=USER_TEST.format(level=40))
    pytester.runpytest("--regen-baselines").assert_outcomes(passed=1)
    pytester.makepyfile(test_user=USER_TEST.format(level=200))
    res = pytester.runpytest("--image-report", "report")
    res.assert_outcomes(failed=1)
    res.stdout.fnmatch_lines(["*image_regression test_square: mean abs error*FAIL*result.png*"])
    out = pytester.path / ".image-regression" / "test_square"
    for name in ("result.png", "baseline.png", "diff.png"):
        assert (out / name).is_file(), name
    page = (pytester.path / "report" / "index.html").read_text()
    assert "1 failed" in page and page.count("<img") == 3
    # a small change within the tolerance passes, and the ini option moves the baselines
    pytester.makepyfile(test_user=USER_TEST.format(level=41))
    pytester.runpytest().assert_outcomes(passed=1)
    pytester.makeini("[pytest]\nimage_baseline_dir = golden\n")
    pytester.runpytest().assert_outcomes(failed=1)
    pytester.runpytest("--regen-baselines").assert_outcomes(passed=1)
    assert (pytester.path / "golden" / "test_square.png").is_file()


@pytest.mark.slow
def test_render_results_are_checked(pytester, monkeypatch):
    if KERNEL_CACHE:
        monkeypatch.setenv("SMOOTHDIST_CACHE_DIR", KERNEL_CACHE)
    pytester.makepyfile(test_user="""
        import numpy as np
        import tracer

        def test_sphere(image_regression):
            V = np.array([[0, 0, 0.0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
            res = tracer.render_mesh(V, size=(16, 16))
            image_regression.check(res, name="four points")
    """)
    # in a subprocess: numba cannot be imported afresh in this process
    pytester.runpytest_subprocess("--regen-baselines").assert_outcomes(passed=1)
    assert (pytester.path / "tests" / "baseline" / "four_points.png").is_file()
    pytester.runpytest_subprocess().assert_outcomes(passed=1)


def test_repr_png_is_the_image():
    from PIL import Image

    import tracer

    V = np.array([[0, 0, 0.0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    res = tracer.render_mesh(V, size=(24, 16))
    png = res._repr_png_()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    np.testing.assert_array_equal(np.asarray(Image.open(io.BytesIO(png))), res.rgb)


def test_check_rejects_what_is_not_an_image(pytester):
    pytester.makepyfile(test_user="""
        def test_bad(image_regression):
            image_regression.check([[0.5, 0.2]])
    """)
    res = pytester.runpytest()
    res.assert_outcomes(failed=1)
    res.stdout.fnmatch_lines(["*RenderResult, a PNG path or an (H, W?, C?) uint8 array*"])


def test_a_baseline_of_another_size_fails_naming_both(pytester):
    pytester.makepyfile(test_user=USER_TEST.format(level=40))
    pytester.runpytest("--regen-baselines").assert_outcomes(passed=1)
    pytester.makepyfile(test_user=USER_TEST.format(level=40).replace("_image(40)",
                                                                      "_image(40)[:4]"))
    res = pytester.runpytest()
    res.assert_outcomes(failed=1)
    res.stdout.fnmatch_lines(["*image_regression test_square:*shape*baseline*test_square.png*"])
