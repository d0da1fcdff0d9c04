"""Cost of one animation frame: the bunnies on the bumpy plane (Table 3), lit, 640 x 360.

The frame is frame 600 of ``scenes/simulations/table3/bunny_bunny_plane.json`` as our simulator
ran it: the bodies' poses and the clip's automatic camera are in
``benchmarks/data/bunny_bunny_plane_frame600.json`` (so no simulation is needed), or give your
own run with ``--trajectory DIR/trajectory.npz --frame N`` (then the camera is the automatic
one over that trajectory, as ``tracer simulate`` frames it). Each body's tree is built once;
a frame poses the bodies through the render's per-object transforms, as the clips do.

Variants, each warmed up once and then timed ``--repeat`` times in turn (best reported), in
one process, 2 threads unless ``--threads``: the clip's lit look (soft shadows, ambient
occlusion, 1 sample per pixel), without shadows, without occlusion, and the normal-colour
shading (the primary march alone). The table lists seconds, hit pixels, distance evaluations
and leaves visited by the camera rays.

Usage::

    python benchmarks/bench_frame.py                       # 640 x 360, best of 3
    python benchmarks/bench_frame.py --size 320 180 --repeat 1 --json out.json
"""

import argparse
import dataclasses
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run from a checkout without installing
    sys.path.insert(0, str(ROOT))

import numba  # noqa: E402

from tracer.rendering.renderer import render  # noqa: E402
from tracer.sim.animate import body_scene  # noqa: E402
from tracer.sim.simfile import load_simulation  # noqa: E402

POSES = ROOT / "benchmarks" / "data" / "bunny_bunny_plane_frame600.json"


def frame_scene(size, trajectory=None, frame=None):
    """``(scene, poses)`` of the benchmark frame (or of ``frame`` of ``trajectory``)."""
    if trajectory is None:
        spec = json.loads(POSES.read_text())
        sim = load_simulation(str(ROOT / spec["sim"]))
        scene = body_scene(sim, size)
        cam = spec["camera"]
        scene = dataclasses.replace(scene, camera_origin=np.array(cam["origin"], float),
                                    camera_dest=np.array(cam["dest"], float),
                                    camera_up=np.array(cam["up"], float))
        poses = [(np.array(R, float), np.array(x, float))
                 for R, x in zip(spec["rotations"], spec["centers"])]
    else:
        from tracer.sim.run import load_trajectory

        data = load_trajectory(trajectory)
        sim = load_simulation(str(data["sim_file"]))
        rotations, centers = np.asarray(data["rotations"]), np.asarray(data["centers"])
        scene = body_scene(sim, size, {"rotations": rotations, "centers": centers})
        poses = [(rotations[frame, k], centers[frame, k]) for k in range(len(sim.bodies))]
    return scene, poses


def variants(scene):
    light = scene.lighting
    return {"lit": scene,
            "no shadows": dataclasses.replace(
                scene, lighting=dataclasses.replace(light, shadows=False)),
            "no occlusion": dataclasses.replace(
                scene, lighting=dataclasses.replace(light, ao=False)),
            "normals": dataclasses.replace(scene, shading="normals")}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--size", nargs=2, type=int, default=(640, 360), metavar=("W", "H"))
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--threads", type=int, default=min(2, numba.config.NUMBA_NUM_THREADS))
    p.add_argument("--trajectory", help="a trajectory.npz of your own run (with --frame)")
    p.add_argument("--frame", type=int, default=600)
    p.add_argument("--json", help="write the results here")
    args = p.parse_args(argv)
    if args.repeat < 1 or min(args.size) < 1:
        p.error("--repeat and --size must be positive")
    numba.set_num_threads(args.threads)
    scene, poses = frame_scene(tuple(args.size), args.trajectory,
                               args.frame if args.trajectory else None)
    runs = variants(scene)
    for sc in runs.values():                     # warm-up: compile, build the trees
        render(sc, transforms=poses)
    best = {name: None for name in runs}
    for _ in range(args.repeat):
        for name, sc in runs.items():
            t0 = time.perf_counter()
            res = render(sc, transforms=poses)
            dt = time.perf_counter() - t0
            if best[name] is None or dt < best[name]["seconds"]:
                best[name] = {"seconds": dt, "hits": int(res.hit.sum()),
                              "evaluations": int(res.steps.sum()),
                              "leaves": int(res.leaves.sum())}
    load = "load average %.2f / %.2f / %.2f" % os.getloadavg()
    print(f"bunnies on the plane, frame {args.frame}, {args.size[0]} x {args.size[1]}, "
          f"{args.threads} threads, best of {args.repeat}; {load} after the run")
    print("| variant | seconds | hit pixels | camera-ray evaluations | leaves |")
    print("|---|---:|---:|---:|---:|")
    for name, r in best.items():
        print(f"| {name} | {r['seconds']:.3f} | {r['hits']} | {r['evaluations']} | "
              f"{r['leaves']} |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"size": list(args.size), "threads": args.threads,
                       "repeat": args.repeat, "results": best}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
