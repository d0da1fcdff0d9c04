"""Compile a first render's light kernels in a second process, beside the tree and the trace.

The first render on a machine compiles every kernel it calls, one after the other on one core
(the performance guide's cold-start table says how long). The lit film's light kernels
(shadows, occlusion, the ground, the objects' ids: :func:`tracer.rendering.film.form_image`)
depend on the tree and the trace only through their arrays' types. So, where the per-machine
kernel cache (``smoothdist.warmup.cache_folder``) holds none of them yet,
:func:`tracer.compiling.start_ahead` runs this module's :func:`child_main` in a child process.
It makes a tiny scene of the same build (the number of objects, the mode, ``tol``, the film's
settings: the same kernel types; its trees built by numba's pure-Python functions, which
compiles nothing), compiles the scene's distance (which the trace needs too; the render waits
for that part before its camera check, :func:`tracer.compiling.wait_ahead`), the shading
normals' kernel (the render waits for it after its trace), then runs the film on made-up hits
and the ground probe, and last the samples' kernel of a render of several samples per pixel
(:func:`child_main`). Meanwhile the render loads its mesh, builds its tree and traces; it waits
for the child before its light and before its samples, and loads their kernels.

An unlit render has no light to compile: its child compiles the scene's distance while the
render builds its tree, then the film's (unlit) kernels and the samples', without the shading
normals and the ground probe; its marker in the cache is the distance's index instead of the
light's.

Only the entry points that own their process ask for it (``tracer render``,
:func:`tracer.render_mesh`), with a second core and a cache to fill
(:func:`tracer.compiling.ahead_needed`). ``TRACER_COMPILE_AHEAD=off`` turns it off.
"""

import gc
import json
from dataclasses import replace

import numpy as np

from smoothdist import DataMesh, SmoothDistanceField
from smoothdist.warmup import build_trees_in_python
from tracer.rendering.film import BETA_SHADE, _gradients, _trace, form_image, sample_offsets
from tracer.rendering.frame import (camera_of, distance_at_camera, pixel_buffers, scene_arrays,
                                    trace_options)
from tracer.rendering.lighting import ground_height
from tracer.rendering.renderer import ray_args
from tracer.scenes.scene import scene_from_field

__all__ = ["tiny_scene", "run_film", "run_normals", "run_ground", "run_samples",
           "child_main"]


def tiny_scene(cfg, lighting=None):
    """A scene of ``cfg["objects"]`` octahedra (8 triangles each) with ``cfg``'s settings, a
    camera on the z axis; its trees built without compiling. ``lighting``: the lit shading's
    settings (None: the defaults)."""
    build_trees_in_python()      # the mesh has 8 triangles: nothing to compile
    V = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    F = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5],
                  [0, 3, 5]])
    field = SmoothDistanceField(DataMesh(V, triangles=F))
    scene = scene_from_field(field, alpha=10.0, beta=cfg["beta"], mode=cfg["mode"],
                             tol=cfg["tol"], width=8, height=8, shading=cfg["shading"],
                             samples=cfg["samples"], adaptive=cfg["adaptive"],
                             transparent=cfg["transparent"], lighting=lighting,
                             camera=((0.0, 0.0, 6.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0)))
    if cfg["objects"] > 1:
        first = scene.objects[0]
        scene.objects = [replace(first, name=f"o{k}", field=SmoothDistanceField(
            DataMesh(V + [3.0 * k, 0.0, 0.0], triangles=F))) for k in range(cfg["objects"])]
    return scene


def run_film(scene):
    """The film of ``scene`` on made-up hits (a 4 x 4 block of the image): the kernels of
    :func:`tracer.rendering.film.form_image` compiled for ``scene``'s types."""
    camera = camera_of(scene)
    arrays = scene_arrays(scene)
    hit, tbuf, grad, steps, leaves, bis, objs = pixel_buffers(scene.film.height,
                                                              scene.film.width)
    hit[2:6, 2:6] = True
    tbuf[hit] = 5.0
    grad[hit] = (0.0, 0.0, 1.0)
    objs[hit] = 0
    form_image(scene, camera, arrays, ray_args(scene, camera, arrays),
               trace_options(scene, arrays.lo, arrays.hi), (hit, tbuf, grad, objs))


def run_normals(scene):
    """The shading normals' kernel (:func:`tracer.rendering.march.gradient_tasks`, through
    ``tracer.rendering.film._gradients``) compiled for ``scene``'s types, on four rays."""
    camera = camera_of(scene)
    arrays = scene_arrays(scene)
    _gradients(ray_args(scene, camera, arrays), arrays.depth_max, np.arange(4, dtype=np.int64),
               scene.film.width, np.zeros((1, 2)), np.full(4, 5.0))


def run_ground(scene):
    """The ground probe (:func:`tracer.rendering.lighting.ground_height`) compiled for
    ``scene``'s types."""
    arrays = scene_arrays(scene)
    verts = np.concatenate([o.field.mesh.V for o in scene.objects])
    ground_height(arrays, verts, np.array([0.0, 1.0, 0.0]), scene.march.eps)


def run_samples(scene):
    """The anti-aliasing samples' kernel (:func:`tracer.rendering.march.sample_tasks`, through
    ``tracer.rendering.film._trace``) compiled for ``scene``'s types, on two rays."""
    camera = camera_of(scene)
    arrays = scene_arrays(scene)
    _trace(ray_args(scene, camera, arrays), arrays.depth_max,
           trace_options(scene, arrays.lo, arrays.hi), np.arange(2, dtype=np.int64),
           scene.film.width, sample_offsets(2)[1:])


def child_main(text):
    """The child, for the JSON ``text`` (:func:`tracer.compiling.ahead_config`), in the order
    the render needs them; it says ``distance``, ``normals``, ``light`` and ``done`` as each is
    in the cache (:data:`tracer.compiling.AHEAD_TAGS`):

    * the scene's distance (the render's trace needs it);
    * the shading normals' kernel of a lit render in smooth mode (:func:`run_normals`; the
      render needs it right after its trace);
    * :func:`run_film` of :func:`tiny_scene` without the ground, one sample per pixel and the
      render's own field (beta at most :data:`~tracer.rendering.film.BETA_SHADE`, so no shading
      normals again): the light's kernels (shadows, occlusion, the objects' ids), then the
      ground probe of a lit render (:func:`run_ground`). The probe marches with the trace's
      ``march_ray``, which the render compiles as soon as this process has said ``distance``
      (:func:`tracer.rendering.march.compile_march`): by then it is in the cache, and this
      process loads it instead of compiling it a second time;
    * a render of more than one sample per pixel: the samples' kernel
      (:func:`run_samples`), which the render needs after its light."""
    cfg = json.loads(text)
    scene = tiny_scene(dict(cfg, samples=1, adaptive=False, beta=min(cfg["beta"], BETA_SHADE)),
                       lighting={"ground": False})
    distance_at_camera(scene)       # the scene's distance first: the render's trace needs it
    print("distance", flush=True)
    lit = cfg["shading"] == "lit"
    if lit and cfg["mode"] == "smooth" and cfg["beta"] > BETA_SHADE:
        run_normals(scene)
    print("normals", flush=True)
    run_film(scene)
    if lit:
        run_ground(scene)
    print("light", flush=True)
    if cfg["samples"] > 1:
        run_samples(scene)
    print("done", flush=True)
    # the render waits for this process to end: Python's last garbage collection would walk
    # every object numba made here (as tracer.cli's own process, frozen)
    gc.freeze()
