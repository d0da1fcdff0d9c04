"""tracer: sphere tracing of smooth-distance isosurfaces (Madan & Levin 2022).

The one-call entry point is :func:`render_mesh` (``tracer.render_mesh(mesh)`` -> arrays);
:func:`mesh_scene`, :func:`scene_from_field` and ``tracer.render.render`` are the steps it
takes. They are imported on first use, so ``import tracer`` (and the command line) stays
light.
"""

_LAZY = {
    "render_mesh": "tracer.from_mesh",
    "mesh_scene": "tracer.from_mesh",
    "scene_from_field": "tracer.scene",
    "load_scene": "tracer.scene",
}

__all__ = sorted(_LAZY)


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'tracer' has no attribute {name!r}")
