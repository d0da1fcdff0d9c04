"""``tracer warmup``: compile the library's and the renderer's kernels ahead, on every core.

The jobs of :mod:`smoothdist.warmup` and the renderer's first calls below, each a ``tracer``
command on a small mesh written into a temporary folder (a triangle mesh, its exact offset
surface, its edges with a tolerance, points on it, the lit adaptive look, a simulation step when
the sim extra is installed), run in child processes side by side
(:func:`smoothdist.warmup.run`); every kernel they compile lands in the per-machine cache, so
that a user's first render loads it. Once per machine and version: after ``pip install``, in a
Docker image, before a CI suite.
"""

import importlib.util
import os
import tempfile

import numpy as np

from smoothdist import warmup
from tracer.cli import main

HELP = "compile the kernels ahead (once per machine and version), side by side on every core"

#: the render jobs' image size: the kernels compiled do not depend on it
SIZE = ("--size", "64", "64")

#: a one-step simulation of two bodies made from built-in primitives (no file needed)
SIM_SCENE = """{"name": "warmup", "dt": 0.005, "steps": 1, "gravity": [0, 0, -9.81],
"beta": 0.5, "camera": {"origin": [0, -5.2, 2.6], "dest": [0, 0, -1.0], "up": [0, 0, 1],
"width": 64, "height": 48},
"bodies": [{"name": "bowl", "primitive": {"type": "hemisphere_net", "radius": 2.0, "rings": 3,
"segments": 8}, "alpha": 20, "static": true},
{"name": "ico", "primitive": {"type": "icosphere", "radius": 0.45, "subdivisions": 1},
"kind": "edges", "alpha": 20, "density": 1, "position": [-1.0, 0.3, 0.2]}]}"""


def _write_inputs(folder):
    """A sphere as OBJ triangles, its edges as OBJ lines and 500 points on it; their paths."""
    import trimesh  # trimesh (tracer extra): loaded on use, in the job's child only

    mesh = trimesh.creation.icosphere(subdivisions=2)
    V, F = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    paths = {k: os.path.join(folder, n) for k, n in
             (("triangles", "ball.obj"), ("edges", "wire.obj"), ("points", "cloud.xyz"))}
    with open(paths["triangles"], "w", encoding="ascii") as f:
        f.writelines(f"v {x:.9f} {y:.9f} {z:.9f}\n" for x, y, z in V)
        f.writelines(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in F)
    with open(paths["edges"], "w", encoding="ascii") as f:
        f.writelines(f"v {x:.9f} {y:.9f} {z:.9f}\n" for x, y, z in V)
        f.writelines(f"l {a + 1} {b + 1}\n" for a, b in mesh.edges_unique)
    P = np.random.default_rng(0).normal(size=(500, 3))
    np.savetxt(paths["points"], P / np.linalg.norm(P, axis=1, keepdims=True))
    return paths


def _command(kind, *extra, sim=False):
    """A job: ``tracer render`` of the ``kind`` input (or ``tracer simulate``) in a temporary
    folder; raises on a non-zero exit."""

    def job():
        with tempfile.TemporaryDirectory(prefix="tracer-warmup-") as tmp:
            if sim:
                scene = os.path.join(tmp, "sim.json")
                with open(scene, "w", encoding="ascii") as f:
                    f.write(SIM_SCENE)
                argv = ["simulate", scene, "--steps", "1", "--no-render", "-o",
                        os.path.join(tmp, "sim"), "--overwrite"]
            else:
                argv = ["render", _write_inputs(tmp)[kind], *SIZE, *extra, "-o",
                        os.path.join(tmp, "out.png"), "--overwrite", "-q"]
            rc = main(argv)
        if rc != 0:
            raise SystemExit(f"tracer {' '.join(argv[:1])} exited {rc}")

    return job


def _simulation():
    if importlib.util.find_spec("scipy") is None:  # the sim extra is not installed: nothing
        return lambda: None
    return _command(None, sim=True)


#: the renderer's jobs, longest first; the library's come from :mod:`smoothdist.warmup`
JOBS = warmup._Lazy({
    "render-mesh": lambda: _command("triangles"),
    "render-lit": lambda: _command("triangles", "--shading", "lit", "--samples", "16",
                                   "--adaptive"),
    "render-exact": lambda: _command("triangles", "--mode", "exact"),
    "render-edges": lambda: _command("edges", "--tol", "1e-3"),  # tolerance pruning
    "render-points": lambda: _command("points"),
    "simulate": _simulation,
})
#: ``{job: jobs it waits for}``: ``render-mesh`` loads the trees' kernels that the first
#: ``MeshDistance`` call compiles (meanwhile the second core takes the library's next job; on 2
#: cores the warm-up ended sooner than with both starting at once, in two rounds in turn);
#: the other renders share most of ``render-mesh``'s kernels; the exact offset surface and a
#: smooth one pruned with a tolerance share a march of their own (26 specialisations), which
#: the edges render (``--tol``) loads once ``render-exact`` has made it
AFTER = {"render-mesh": ("mesh-distance",), "render-lit": ("render-mesh",),
         "render-exact": ("render-mesh",), "render-edges": ("render-exact",),
         "render-points": ("render-mesh",), "simulate": ("mesh-distance",)}

#: the modules whose jobs ``tracer warmup`` runs
MODULES = ("smoothdist.warmup", "tracer.cli_warmup")


def add_arguments(p):
    warmup.add_arguments(p)


def needs(args):
    """The renders write PNGs (Pillow) and read the sphere from trimesh; ``--list`` needs
    nothing."""
    return [] if args.list else ["PIL", "trimesh"]


def run(args):
    return warmup.warmup_command(args, MODULES)
