"""Compile a first render's kernels in a second process, beside the tree and the trace.

The first render on a machine compiles every kernel it calls, one after the other on one core
(the performance guide's cold-start table says how long). The trace's and the film's kernels
(shadows, occlusion, the ground, the objects' ids: :func:`tracer.rendering.film.form_image`)
depend on the tree only through their arrays' types. So, where the per-machine kernel cache
(``smoothdist.warmup.cache_folder``) holds none of them yet,
:func:`tracer.compiling.start_ahead` runs this module's :func:`child_main` in a child process.
It makes a tiny scene of the same build (the number of objects, the mode, ``tol``, the film's
settings: the same kernel types; its trees built by numba's pure-Python functions, which
compiles nothing) and compiles the scene's distance first (the trace needs it too; the render
waits for that part before its camera check, :func:`tracer.compiling.wait_ahead`).

Then the two processes share out the rest through files in a folder of their own
(:func:`tracer.compiling.claim_job`): the trace kernel goes to whichever asks first. A render
still loading its data (a point cloud's spacing probes, a wire mesh's automatic alpha) leaves
it to the child, and compiles the film's kernels itself meanwhile, on an 8 x 8 image of its own
scene (:func:`tracer.rendering.renderer.compile_film`). A render that is ready first traces,
and the child compiles the film: the shading normals' kernel (the render waits for it after its
trace), the light on made-up hits, the ground probe, and last the samples' kernel of a render
of several samples per pixel (:func:`child_main`). The render loads what the other process
compiled.

An unlit render has no light to compile: its child compiles the scene's distance while the
render builds its tree, then the trace or the film's (unlit) kernels and the samples', without
the shading normals and the ground probe; its marker in the cache is the distance's index
instead of the light's.

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
from tracer.compiling import claim, wait_for
from tracer.rendering.film import BETA_SHADE
from tracer.rendering.frame import distance_at_camera
from tracer.rendering.renderer import run_film, run_ground, run_normals, run_samples, run_trace
from tracer.scenes.scene import scene_from_field

__all__ = ["tiny_scene", "child_main"]


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


def child_main(text):
    """The child, for the JSON ``text`` (:func:`tracer.compiling.ahead_config`, with the folder
    ``claims`` where it and the render share out their jobs), in the order the render needs
    them; it says ``distance``, ``march``, ``trace``, ``normals``, ``light`` and ``done`` as
    each is in the cache, or at once where it is the render's job
    (:data:`tracer.compiling.AHEAD_TAGS`):

    * the scene's distance (the render's camera check and its trace need it);
    * the trace kernel, where it takes it (:func:`tracer.compiling.claim_trace`: the render has
      not taken it yet, it is still loading its data or building its tree), the march first
      (:func:`~tracer.rendering.renderer.run_trace`); the render compiles the film's kernels
      meanwhile (:func:`tracer.rendering.renderer.compile_film`). Otherwise the film's:
    * the shading normals' kernel of a lit render in smooth mode
      (:func:`~tracer.rendering.renderer.run_normals`; the render needs it right after its
      trace);
    * :func:`~tracer.rendering.renderer.run_film` of :func:`tiny_scene` without the ground, one
      sample per pixel and the render's own field (beta at most
      :data:`~tracer.rendering.film.BETA_SHADE`, so no shading normals again): the light's
      kernels (shadows, occlusion, the objects' ids), then the ground probe of a lit render
      (:func:`~tracer.rendering.renderer.run_ground`). The probe marches with the trace's
      ``march_ray``, which the render compiles as soon as this process has said ``distance``
      (:func:`tracer.rendering.march.compile_march`): by then it is in the cache, and this
      process loads it instead of compiling it a second time;
    * a render of more than one sample per pixel: the samples' kernel
      (:func:`~tracer.rendering.renderer.run_samples`), which the render needs after its
      light."""
    cfg = json.loads(text)
    scene = tiny_scene(dict(cfg, samples=1, adaptive=False, beta=min(cfg["beta"], BETA_SHADE)),
                       lighting={"ground": False})
    distance_at_camera(scene)       # the scene's distance first: the render's trace needs it
    _say("distance")
    lit = cfg["shading"] == "lit"
    if cfg.get("claims") and claim(cfg["claims"], "trace"):
        _say("normals")             # the film is the render's
        _say("light")
        run_trace(scene, said=_say)
        _say("trace")
    else:
        _say("march")               # the trace is the render's
        _say("trace")
        if lit and cfg["mode"] == "smooth" and cfg["beta"] > BETA_SHADE:
            run_normals(scene)
        _say("normals")
        run_film(scene)
        if lit:
            if cfg.get("claims"):
                wait_for(cfg["claims"], "march")    # the render's march, which the probe loads
            run_ground(scene)
        _say("light")
    if cfg["samples"] > 1 and (not cfg.get("claims") or claim(cfg["claims"], "samples")):
        run_samples(scene)
    _say("samples")
    _say("done")
    # the render waits for this process to end: Python's last garbage collection would walk
    # every object numba made here (as tracer.cli's own process, frozen)
    gc.freeze()


def _say(tag):
    print(tag, flush=True)
