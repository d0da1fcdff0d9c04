"""``tracer diff``: compare two images; exit status 1 when they differ beyond a tolerance.

``tracer diff A.png B.png [-o DIFF.png] [--tol T] [--threshold 16] [--max-fraction F]``
prints the mean absolute error (0-255 units, over all pixels and channels), the fraction of
pixels whose largest channel difference exceeds ``--threshold`` and the largest error, and
exits

* 0 when ``mean abs error <= --tol`` (default 1.0) and, if ``--max-fraction`` is given, the
  fraction of pixels over the threshold is ``<= --max-fraction``;
* 1 otherwise (the failed criteria are named);
* 2 for bad input: a missing or unreadable file, images of different sizes, a bad option
  (one ``error: ...`` line, as every ``tracer`` command).

``-o DIFF.png`` writes the heat map of :func:`tracer.image.compare_images` (black where the
images agree, ``inferno`` up to the largest difference), in every case where both images could
be read. The same check is available to Python code as :func:`check_images`, which the image
regression tests use.
"""

import math
import sys
from typing import NamedTuple

from tracer.errors import CLIError
from tracer.image import compare_images, save_png
from tracer.outputs import check_outputs

__all__ = ["DiffVerdict", "check_images", "HELP", "add_arguments", "needs", "run"]

HELP = "compare two images; non-zero exit beyond a tolerance"


class DiffVerdict(NamedTuple):
    """Outcome of :func:`check_images`.

    diff : tracer.image.ImageDiff
        The metrics and the heat map.
    passed : bool
        True when every criterion holds.
    failures : tuple of str
        One phrase per failed criterion, e.g. ``"mean abs error 3.2 > tol 1"``.
    tol, threshold, max_fraction
        The criteria used (``max_fraction`` None: not checked).
    """

    diff: object
    passed: bool
    failures: tuple
    tol: float
    threshold: int
    max_fraction: object

    def summary(self):
        """One line: the metrics, the criteria and PASS / FAIL."""
        d = self.diff
        frac = (f"{100 * d.fraction_over:.3f}% of pixels over {self.threshold}"
                + (f" (max {100 * self.max_fraction:.3f}%)" if self.max_fraction is not None
                   else ""))
        verdict = "PASS" if self.passed else "FAIL: " + "; ".join(self.failures)
        return (f"mean abs error {d.mean_abs_error:.4f} (tol {self.tol:g}), {frac}, "
                f"max error {d.max_abs_error}: {verdict}")


def _check_criteria(tol, threshold, max_fraction):
    if not (isinstance(tol, (int, float)) and math.isfinite(tol) and tol >= 0):
        raise ValueError(f"the tolerance must be a finite number >= 0, got {tol!r}")
    if isinstance(threshold, bool) or not isinstance(threshold, int) or not 0 <= threshold <= 255:
        raise ValueError(f"the threshold must be an integer in 0..255, got {threshold!r}")
    if max_fraction is not None and not (isinstance(max_fraction, (int, float))
                                         and 0.0 <= max_fraction <= 1.0):
        raise ValueError(f"the maximum fraction must be in 0..1, got {max_fraction!r}")


def check_images(a, b, tol=1.0, threshold=16, max_fraction=None):
    """Compare two images against a tolerance.

    Parameters
    ----------
    a, b : (H, W, 3) or (H, W) uint8 array, or path
        As for :func:`tracer.image.compare_images`.
    tol : float, default 1.0
        Largest accepted mean absolute error (0-255 units).
    threshold : int, default 16
        A pixel is "over" when its largest channel difference exceeds this.
    max_fraction : float in 0..1, optional
        Largest accepted fraction of pixels over ``threshold``; None: not checked.

    Returns
    -------
    DiffVerdict

    Raises
    ------
    ValueError
        Shapes differ, an input is not a uint8 image or cannot be decoded, or a bad criterion.
    FileNotFoundError
        A path that does not exist.
    """
    _check_criteria(tol, threshold, max_fraction)
    diff = compare_images(a, b, threshold=threshold)
    failures = []
    if not diff.mean_abs_error <= tol:
        failures.append(f"mean abs error {diff.mean_abs_error:.4g} > tol {tol:g}")
    if max_fraction is not None and not diff.fraction_over <= max_fraction:
        failures.append(f"{100 * diff.fraction_over:.3g}% of pixels over {threshold} > "
                        f"{100 * max_fraction:.3g}%")
    return DiffVerdict(diff=diff, passed=not failures, failures=tuple(failures), tol=float(tol),
                       threshold=int(threshold), max_fraction=max_fraction)


def add_arguments(p):
    """Arguments of ``tracer diff``."""
    p.add_argument("a", metavar="A.png", help="first image")
    p.add_argument("b", metavar="B.png", help="second image (same size)")
    p.add_argument("-o", "--output", metavar="DIFF.png", help="write the difference heat map")
    p.add_argument("--tol", type=float, default=1.0,
                   help="largest accepted mean absolute error, 0-255 units (default 1.0)")
    p.add_argument("--threshold", type=int, default=16,
                   help="per-pixel difference counted as 'over' (default 16)")
    p.add_argument("--max-fraction", type=float, metavar="F",
                   help="largest accepted fraction (0-1) of pixels over the threshold "
                        "(default: not checked)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing DIFF.png")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing; exit status only")


def needs(args):
    """Pillow reads the images, matplotlib colours the heat map that every comparison makes
    (:func:`tracer.image.compare_images`); :mod:`tracer.cli` checks them first."""
    return ["matplotlib", "PIL"]


def run(args):
    """Compare; returns 0 (within tolerance) or 1 (beyond); bad input raises (status 2)."""
    if not math.isfinite(args.tol) or args.tol < 0:
        raise CLIError(f"--tol must be a finite number >= 0, got {args.tol}")
    if not 0 <= args.threshold <= 255:
        raise CLIError(f"--threshold must be in 0..255, got {args.threshold}")
    if args.max_fraction is not None and not 0.0 <= args.max_fraction <= 1.0:
        raise CLIError(f"--max-fraction must be in 0..1, got {args.max_fraction}")
    if args.output is not None:
        if not args.output.lower().endswith(".png"):
            raise CLIError(f"-o must name a .png file, got {args.output}")
        check_outputs([args.output], args.overwrite)
    verdict = check_images(args.a, args.b, tol=args.tol, threshold=args.threshold,
                           max_fraction=args.max_fraction)
    if args.output is not None:
        save_png(args.output, verdict.diff.diff, overwrite=args.overwrite)
    if not args.quiet:
        print(verdict.summary() + (f" Wrote {args.output}." if args.output else ""))
        sys.stdout.flush()
    return 0 if verdict.passed else 1
