"""Image regression tests for users' renders: the ``image_regression`` pytest fixture.

Registered with pytest's ``pytest11`` entry point, so a test suite gets it by installing the
package::

    def test_my_render(image_regression):
        res = tracer.render_mesh("my.obj", size=(128, 128))
        image_regression.check(res)                       # or an (H, W, 3) uint8 array

* Baselines are PNG files ``<name>.png`` in the folder set by the ini option
  ``image_baseline_dir`` (default ``tests/baseline``, relative to the rootdir); ``name``
  defaults to the test's name (parameters included).
* ``pytest --regen-baselines`` writes them (never implicitly: a missing baseline fails).
* A comparison (:func:`tracer.checks.imagediff.check_images`: mean absolute error ``<= tol``, and at
  most ``max_fraction`` of pixels differing by more than ``threshold``) that fails writes the
  result, the baseline and the difference heat map to ``<image_failed_dir>/<name>/`` (ini
  option, default ``.image-regression``) and names them in the assertion.
* ``pytest --image-report DIR`` writes ``DIR/index.html``: every comparison of the run with the
  three images and its metrics.
"""

import html
import os
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from tracer.checks.imagediff import check_images
from tracer.image import load_png, save_png

__all__ = ["image_regression", "ImageRegression", "write_report"]

DEFAULT_BASELINE_DIR = "tests/baseline"
DEFAULT_FAILED_DIR = ".image-regression"


def pytest_addoption(parser):
    group = parser.getgroup("image regression (tracer)")
    group.addoption("--regen-baselines", action="store_true", default=False,
                    help="write the image_regression baselines from this run's images")
    group.addoption("--image-report", metavar="DIR", default=None,
                    help="write an HTML page of every image comparison to DIR/index.html")
    parser.addini("image_baseline_dir", default=DEFAULT_BASELINE_DIR,
                  help="folder of the image_regression baselines, relative to the rootdir")
    parser.addini("image_failed_dir", default=DEFAULT_FAILED_DIR,
                  help="folder for the images of failed comparisons, relative to the rootdir")


def _as_rgb(image):
    """A uint8 image from a :class:`tracer.rendering.frame.RenderResult`, an array or a PNG path."""

    if hasattr(image, "rgb"):
        image = image.rgb
    if isinstance(image, (str, os.PathLike)):
        return load_png(image)
    arr = np.asarray(image)
    if arr.dtype != np.uint8 or arr.ndim not in (2, 3):
        raise TypeError(f"image_regression.check takes a RenderResult, a PNG path or an "
                        f"(H, W[, C]) uint8 array; got {type(image).__name__} "
                        f"{getattr(arr, 'dtype', '')} {getattr(arr, 'shape', '')}")
    return arr


def _safe(name):
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("_") or "image"


class ImageRegression:
    """The ``image_regression`` fixture's object (see the module docstring)."""

    def __init__(self, request, records):
        config = request.config
        root = Path(str(config.rootpath))
        self.baseline_dir = root / config.getini("image_baseline_dir")
        self.failed_dir = root / config.getini("image_failed_dir")
        self.regen = config.getoption("--regen-baselines")
        self.test_name = request.node.name
        self.records = records
        self._count = 0

    def check(self, image, name=None, tol=1.0, threshold=16, max_fraction=None):
        """Compare ``image`` with the baseline ``name`` (default: the test's name, with
        ``-1``, ``-2``, ... for further checks in the same test). Returns the
        :class:`tracer.checks.imagediff.DiffVerdict`; fails the test when the images differ beyond
        the criteria, when the baseline is missing, or when the shapes differ."""

        rgb = _as_rgb(image)
        if name is None:
            name = self.test_name + (f"-{self._count}" if self._count else "")
        self._count += 1
        name = _safe(name)
        baseline = self.baseline_dir / f"{name}.png"
        if self.regen:
            self.baseline_dir.mkdir(parents=True, exist_ok=True)
            save_png(baseline, rgb, overwrite=True)
            self.records.append({"name": name, "status": "regenerated", "result": baseline})
            return None
        if not baseline.is_file():
            pytest.fail(f"image_regression: no baseline {baseline}; run pytest with "
                        f"--regen-baselines to write it", pytrace=False)
        try:
            verdict = check_images(rgb, baseline, tol=tol, threshold=threshold,
                                   max_fraction=max_fraction)
        except ValueError as exc:  # shapes differ
            pytest.fail(f"image_regression {name}: {exc} (baseline {baseline})", pytrace=False)
        out = self.failed_dir / name
        record = {"name": name, "status": "passed" if verdict.passed else "failed",
                  "summary": verdict.summary(), "baseline": baseline}
        if not verdict.passed:
            out.mkdir(parents=True, exist_ok=True)
            result, diff = out / "result.png", out / "diff.png"
            save_png(result, rgb, overwrite=True)
            save_png(diff, verdict.diff.diff, overwrite=True)
            shutil.copyfile(baseline, out / "baseline.png")
            record.update(result=result, diff=diff)
            self.records.append(record)
            pytest.fail(f"image_regression {name}: {verdict.summary()}; wrote {result}, "
                        f"{out / 'baseline.png'} and {diff}", pytrace=False)
        record["result"] = baseline
        self.records.append(record)
        return verdict


def pytest_configure(config):
    config._image_regression_records = []


@pytest.fixture
def image_regression(request):
    """Compare images with baselines: ``image_regression.check(render_result_or_array)``."""
    return ImageRegression(request, request.config._image_regression_records)


def pytest_sessionfinish(session, exitstatus):
    folder = session.config.getoption("--image-report")
    records = getattr(session.config, "_image_regression_records", [])
    if folder:
        write_report(Path(folder), records)


def write_report(folder, records):
    """``folder/index.html``: one row per comparison, with its images (copied next to the
    page) and metrics."""
    folder.mkdir(parents=True, exist_ok=True)
    rows = []
    for i, rec in enumerate(records):
        cells = []
        for key in ("result", "baseline", "diff"):
            src = rec.get(key)
            if src is None or not Path(src).is_file():
                cells.append("<td></td>")
                continue
            dst = folder / f"{i:04d}-{key}.png"
            shutil.copyfile(src, dst)
            cells.append(f'<td><img src="{dst.name}" alt="{key}"></td>')
        rows.append(f"<tr class=\"{rec['status']}\"><td>{html.escape(rec['name'])}</td>"
                    f"<td>{rec['status']}</td><td>{html.escape(rec.get('summary', ''))}</td>"
                    + "".join(cells) + "</tr>")
    page = ("<!doctype html><meta charset=\"utf-8\"><title>Image comparisons</title>"
            "<style>td{padding:4px;vertical-align:top}img{max-width:256px;"
            "image-rendering:pixelated}.failed{background:#fdd}</style>"
            f"<h1>Image comparisons: {len(records)}, "
            f"{sum(r['status'] == 'failed' for r in records)} failed</h1>"
            "<table><tr><th>name</th><th>status</th><th>metrics</th><th>result</th>"
            "<th>baseline</th><th>difference</th></tr>" + "".join(rows) + "</table>")
    (folder / "index.html").write_text(page, encoding="utf-8")
    return folder / "index.html"
