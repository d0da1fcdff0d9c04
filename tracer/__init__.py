"""tracer: sphere tracing of smooth-distance isosurfaces (Madan & Levin 2022).

The one-call entry point is :func:`render_mesh` (``tracer.render_mesh(mesh)`` -> a
:class:`RenderResult` of numpy arrays); :func:`mesh_scene`, :func:`scene_from_field` and
:func:`render` (``tracer.render(scene)``) are the steps it takes, :func:`load_scene` reads a
scene file, :func:`check_images` compares two images as the image-regression tests do, and
:func:`show_animation` plays frames inline in Jupyter; :class:`Lighting` holds the settings
of the ``"lit"`` shading. The error types are in :mod:`tracer.errors`. The names are imported
on first use, so ``import tracer`` (and the command line) stays light.

The parts are rooms (docs/design-notes.md has the map): the base modules at the top level
(errors, checks of values, output files, PNG files, the task runner), :mod:`tracer.rendering`
(rays, kernels, film, ``render``), :mod:`tracer.scenes` (settings, scene files,
``render_mesh``), :mod:`tracer.checks` (image comparisons), the command line
(:mod:`tracer.cli`), and :mod:`tracer.sim`, :mod:`tracer.studies` and ``tracer.reproduce``.
"""

import importlib

from tracer import _moved  # noqa: F401  (the old paths' import hook)

_LAZY = {
    "render_mesh": "tracer.scenes.from_mesh",
    "mesh_scene": "tracer.scenes.from_mesh",
    "scene_from_field": "tracer.scenes.scene",
    "load_scene": "tracer.scenes.scene",
    "Scene": "tracer.scenes.scene",
    "SceneObject": "tracer.scenes.scene",
    "render": "tracer.rendering.renderer",
    "RenderResult": "tracer.rendering.renderer",
    "check_images": "tracer.checks.imagediff",
    "show_animation": "tracer.checks.notebook",
    "Lighting": "tracer.rendering.lighting",
}

__all__ = sorted(_LAZY)


def __getattr__(name):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'tracer' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
