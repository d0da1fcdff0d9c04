"""The scenes room: what a render is asked to draw.

The settings table (:mod:`~tracer.scenes.settings`), the :class:`~tracer.Scene` and its file
format (:mod:`~tracer.scenes.scene`, :mod:`~tracer.scenes.scene_schema`, the JSON Schema
``scene.schema.json`` beside them) and the one call from a mesh to a render
(:mod:`~tracer.scenes.from_mesh`). Nothing is imported here.
"""
