"""tracer: sphere tracing of smooth-distance isosurfaces (Madan & Levin 2022).

The one-call entry point is :func:`render_mesh` (``tracer.render_mesh(mesh)`` -> a
:class:`RenderResult` of numpy arrays); :func:`mesh_scene`, :func:`scene_from_field` and
:func:`render` (``tracer.render(scene)``) are the steps it takes, :func:`load_scene` reads a
scene file, :func:`check_images` compares two images as the image-regression tests do, and
:func:`show_animation` plays frames inline in Jupyter; :class:`Lighting` holds the settings
of the ``"lit"`` shading. The error types are in :mod:`tracer.errors`. The names are listed
once, in ``tracer/__init__.pyi`` (each from the module that defines it, which editors follow),
and imported on first use (:mod:`tracer.lazy`), so ``import tracer`` (and the command line)
stays light.

The parts are rooms (docs/design-notes.md has the map): the base modules at the top level
(errors, checks of values, output files, PNG files, the task runner), :mod:`tracer.rendering`
(rays, kernels, film, ``render``), :mod:`tracer.scenes` (settings, scene files,
``render_mesh``), :mod:`tracer.checks` (image comparisons), the command line
(:mod:`tracer.cli`), and :mod:`tracer.sim`, :mod:`tracer.studies` and ``tracer.reproduce``.
"""

from tracer import _moved  # noqa: F401  (the old paths' import hook)
from tracer.lazy import attach_stub

__getattr__, __dir__, __all__ = attach_stub(__name__, __file__)
