"""The error types of the tracer, in one place.

Every one is an :class:`Exception` whose message is one line that names the file, key or option
at fault; :func:`tracer.cli.main` prints it as ``error: ...`` and exits with status 2.

* :class:`TracerError`: the base class of the others;
* :class:`CLIError`: a bad command-line option or output path;
* :class:`SceneError`: a scene file (or another JSON input) that cannot be used, and
  :class:`SimFileError`, the same for a simulation file;
* :class:`RenderError`: a scene that cannot be rendered as asked (camera inside the surface);
* :class:`OverlapError`: simulated bodies that overlap in their initial state;
* :class:`InfeasibleStart`: an interior-point solve started at a point that violates the
  constraint.

The input errors (all but :class:`CLIError`) are also :class:`ValueError`\\ s, so code that
catches ``ValueError`` around a render or a load keeps working. Only the standard library is
imported here.
"""

import os
import sys

__all__ = ["TracerError", "CLIError", "SceneError", "SimFileError", "RenderError",
           "OverlapError", "InfeasibleStart", "ThinFeatureWarning", "user_stacklevel"]

#: the tracer package's folder (frames of its modules are not the user's)
_PACKAGE = os.path.dirname(os.path.abspath(__file__)) + os.sep


def user_stacklevel():
    """The ``stacklevel`` for ``warnings.warn`` in the function that calls this one, such that
    the warning names the first caller outside the tracer package (the user's line), however
    many of the package's functions lie between (``render_mesh`` -> ``build_mesh_scene`` ->
    ...)."""
    frame, level = sys._getframe(1), 1
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(_PACKAGE):
        frame, level = frame.f_back, level + 1
    return level


class ThinFeatureWarning(UserWarning):
    """A render whose tubes (edges) are thinner than half a pixel: they show as specks. The
    message gives the alpha that would show them (``tracer render`` prints it as one
    ``warning: ...`` line). Also a point cloud too sparse for its shape: its surface is
    drawn thicker than its spacing (:func:`tracer.scenes.from_mesh.sparse_cloud`)."""


class TracerError(Exception):
    """Base class of the tracer's user-facing errors (one-line messages)."""


class CLIError(TracerError):
    """A bad command-line option or output path: printed as one line, exit status 2."""


class SceneError(TracerError, ValueError):
    """A scene file (or another JSON input file) that cannot be used; the message names the
    file and the bad key."""


class SimFileError(SceneError):
    """A simulation file that cannot be used; the message names the file and the bad key."""


class RenderError(TracerError, ValueError):
    """A scene that cannot be rendered as asked (e.g. camera inside the surface)."""


class OverlapError(TracerError, ValueError):
    """Simulated bodies overlap (or touch the smooth surface) in the initial state."""


class InfeasibleStart(TracerError, ValueError):
    """An interior-point solve whose starting point violates the constraint (``c(x0) <= 0``)."""
