"""tracer: sphere tracing of smooth-distance isosurfaces (Madan & Levin 2022).

The one-call entry point is :func:`render_mesh` (``tracer.render_mesh(mesh)`` -> a
:class:`RenderResult` of numpy arrays); :func:`mesh_scene`, :func:`scene_from_field` and
:func:`tracer.render.render` are the steps it takes, :func:`load_scene` reads a scene file,
:func:`check_images` compares two images as the image-regression tests do, and
:func:`show_animation` plays frames inline in Jupyter; :class:`Lighting` holds the settings
of the ``"lit"`` shading. The error types are in
:mod:`tracer.errors`. The names are imported on first use, so ``import tracer`` (and the command
line) stays light.
"""

_LAZY = {
    "render_mesh": "tracer.from_mesh",
    "mesh_scene": "tracer.from_mesh",
    "scene_from_field": "tracer.scene",
    "load_scene": "tracer.scene",
    "Scene": "tracer.scene",
    "SceneObject": "tracer.scene",
    "RenderResult": "tracer.render",
    "check_images": "tracer.imagediff",
    "show_animation": "tracer.notebook",
    "Lighting": "tracer.lighting",
}

__all__ = sorted(_LAZY)


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'tracer' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
