"""The rendering room: one frame from scene arrays.

Rays (:mod:`~tracer.rendering.camera`), the sphere-tracing kernels
(:mod:`~tracer.rendering.march`), shading and lights (:mod:`~tracer.rendering.shading`,
:mod:`~tracer.rendering.lighting`), the film's samples and tiles
(:mod:`~tracer.rendering.film`), the pieces of a frame (:mod:`~tracer.rendering.frame`,
:mod:`~tracer.rendering.threads`), the GPU path (:mod:`~tracer.rendering.gpu_render`),
the ripple metric of normals against an analytic shape (:mod:`~tracer.rendering.ripple`) and
:func:`tracer.render` itself (:mod:`~tracer.rendering.renderer`). Nothing is imported here:
``import tracer.rendering`` stays light.
"""
