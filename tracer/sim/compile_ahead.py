"""Compile a first simulation step's whole-mesh kernels in a second process.

A first ``tracer simulate`` on a machine compiles every whole-mesh kernel it calls, one after
the other on one core (the performance guide's cold-start table: about 25 s for
``scenes/simulations/ico_bowl.json``). They come in this order: the smooth distance of the
initial-state check (``MeshDistance.__call__``), its exact distance (``MeshDistance.exact``),
then the first step's distance with its couple (``MeshDistance.with_couple``: the moments'
kernel, the largest). That kernel depends on the data mesh only through its kinds and on the
query mesh through its kinds and size (which choose the kernels). So, where the per-machine
kernel cache holds no moments' kernel yet, :func:`start` runs this module's
:func:`child_main` in a child process (:func:`tracer.compiling.spawn_ahead`): it reads the
same simulation file, puts each pair's real query mesh against a data mesh of two primitives
of each of the data body's kinds (its tree built by numba's pure-Python functions, which
compiles nothing), and calls ``with_couple`` on it. Meanwhile the simulation builds its trees
and compiles the two distances; it waits for the child before its first step
(:func:`tracer.compiling.wait_ahead`) and loads the moments' kernel. (A child that compiled
the exact distance too shared its callees with the smooth distance, which both processes then
compiled at once: the first step came later.)

Only ``tracer simulate`` asks for it (within :func:`tracer.compiling.ahead_allowed`), for the
smooth constraint with exact torques, with a second core and a cache to fill
(:func:`needed`). After that child, a simulation that renders its movie starts the render's
child for the frames' scene (:func:`start_movie`): it compiles their kernels while the
simulation steps. ``TRACER_COMPILE_AHEAD=off`` turns both off.
"""

import gc
import json
import os

import numpy as np

from smoothdist import DataMesh, MeshDistance, SmoothDistanceField
from smoothdist.warmup import build_trees_in_python
from tracer.compiling import ahead_possible, spawn_ahead, start_ahead
from tracer.sim.animate import body_scene
from tracer.sim.constraint import pair_order
from tracer.sim.simfile import load_simulation

__all__ = ["MARKER", "CHILD", "needed", "start", "start_movie", "tiny_data_mesh",
           "child_main"]

#: the moments' kernel, whose cache index says that the simulation's kernels are compiled
MARKER = os.path.join("smoothdist._kernels", "mesh_moment.smooth_moment_primitive_tasks-*.nbi")
#: the child's code: :func:`child_main` of its JSON argument
CHILD = "import sys; from tracer.sim import compile_ahead; compile_ahead.child_main(sys.argv[1])"


def needed(mode, torques):
    """Whether a first step of a simulation with this constraint ``mode`` and ``torques``
    should have a child compile its kernels now: the smooth constraint with exact torques (the
    exact constraint calls the exact distance first, split torques no moments), and
    :func:`tracer.compiling.ahead_possible` without the moments' kernel in the cache."""
    return mode == "smooth" and torques == "exact" and ahead_possible(MARKER)


def start(sim, torques):
    """Start a child compiling the whole-mesh kernels of ``sim``'s first step (a loaded
    :class:`~tracer.sim.simulation.Simulation`; ``torques`` the step's) where :func:`needed`.
    Returns whether one started."""
    if not needed(sim.constraint, torques):
        return False
    return spawn_ahead(CHILD, json.dumps({"sim": os.path.abspath(sim.path)}))


def start_movie(sim, size=None):
    """Start the render's child (:mod:`tracer.scenes.compile_ahead`) for the movie of ``sim``
    (its frames' scene, :func:`tracer.sim.animate.body_scene`, at ``size``), where
    :func:`tracer.compiling.ahead_needed`: it compiles the frames' kernels while the
    simulation steps, and the first frame loads them. Returns whether one started."""
    scene = body_scene(sim, size)
    return start_ahead(scene.march, scene.film, len(scene.objects))


def tiny_data_mesh(mesh):
    """A :class:`smoothdist.DataMesh` with two primitives of each kind ``mesh`` has (points,
    edges, triangles): the same kernels as ``mesh`` as a pair's data."""
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    kinds = {}
    if mesh.points.size:
        kinds["points"] = [0, 3]
    if mesh.edges.size:
        kinds["edges"] = [[0, 1], [1, 2]]
    if mesh.triangles.size:
        kinds["triangles"] = [[0, 1, 2], [0, 2, 3]]
    return DataMesh(V, **kinds)


def child_main(text):
    """The child, for the JSON ``text`` (``{"sim": path}``): every pair of the simulation
    (:func:`tracer.sim.constraint.pair_order`) with its settings, its query body's mesh and
    :func:`tiny_data_mesh` of its data body's, and their distances with their couples (then
    it says ``done``)."""
    sim = load_simulation(json.loads(text)["sim"])
    build_trees_in_python()      # the data meshes have six primitives: nothing to compile
    bodies = sim.bodies
    pairs = [MeshDistance(SmoothDistanceField(tiny_data_mesh(bodies[i].mesh)), bodies[j].mesh,
                          alpha=bodies[i].alpha, alpha_q=bodies[j].alpha, beta=sim.beta,
                          alpha_u=bodies[i].alpha_u, gradient="exact")
             for i, j in pair_order(bodies)]
    R, t = np.eye(3), np.array([0.0, 0.0, 5.0])
    for md in pairs:
        md.with_couple(R, t)
    print("done", flush=True)
    gc.freeze()     # the simulation waits for this process to end: no last collection to walk
