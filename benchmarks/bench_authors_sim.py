"""Side-by-side simulation benchmark: our ``tracer simulate`` against the authors' simulator.

For each simulation file in the authors' format (``objects[]``, ``meshes[]``, ``timestep``,
``num_steps``, ...), both programs run the **same file** with the same meshes, one after the
other in the same run, 2 threads each:

* theirs: ``rigid_body_simulator FILE 2`` (abhimadan/smoothdists, built CPU-only for this
  comparison: ``benchmarks/authors/README.md``), in a scratch folder (it writes
  ``<name>__<object>__state.txt`` and ``__times.txt`` files there);
* ours: ``python -m tracer simulate FILE -o DIR --no-render --threads 2 --scheduler serial``
  (a fresh process, like theirs: start-up, loading numba's cached kernels and BVH builds
  included; an untimed run of the same file before it compiles the kernels if numba's cache
  is cold), with
  ``--torques split`` by default, the equal split of a primitive's force over its vertices
  that their simulator uses (``--torques exact`` for ours at its default).

The copy of the file that both read has its mesh paths made absolute (theirs opens them
relative to the working directory, ours relative to the file) and, with ``--steps N``, its
``num_steps`` set to ``N``; an OBJ file with ``l`` (line) records is copied with them written
as 2-vertex ``f`` records, the only form of an edge their reader takes (ours reads both).

Reported per file: wall seconds of each and their ratio (ours / theirs), distance
evaluations (theirs: lines of the ``__times.txt`` files, one per ``meshDistance`` call;
ours: the trajectory's ``distance_evaluations``), wall milliseconds per evaluation, and the
largest distance between the two centre-of-mass paths of every dynamic object over the run,
in % of the scene size (the diagonal of the bodies' initial bounding box), with the first step
at which it passes 2 %.

Usage::

    python benchmarks/bench_authors_sim.py --authors-bin ../authors-build/bench/rigid_body_simulator \\
        tests/data/authors_sims/cube_plane.json --steps 60
    python benchmarks/bench_authors_sim.py --authors-bin BIN FILE... --json out.json

Their simulator can take hours on a large scene (``cube_cube.json``, two 12-triangle cubes
over 500 steps: 280 s): use ``--steps`` and ``--timeout``. Timings depend on the machine's
load; run on a quiet machine and say so when quoting.
"""

import argparse
import glob
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run from a checkout without installing
    sys.path.insert(0, str(ROOT))

#: a path deviation above this fraction of the scene size counts as "the paths separated"
SEPARATED = 0.02


def prepared_copy(path, folder, steps=None):
    """The file's JSON with absolute mesh paths (and ``num_steps = steps``), written to
    ``folder``; returns ``(new path, spec)``."""
    spec = json.loads(Path(path).read_text())
    base = Path(path).resolve().parent
    for i, obj in enumerate(spec.get("objects", [])):
        for j, mesh in enumerate(obj.get("meshes", [])):
            if "path" in mesh:
                src = (base / mesh["path"]).resolve()
                mesh["path"] = str(src)
                if src.suffix.lower() == ".obj":
                    text = src.read_text()
                    if "\nl " in "\n" + text:
                        # their OBJ reader (igl::readOBJ) skips "l" records and reads an edge
                        # as a 2-vertex "f": both programs read this copy (ours takes either)
                        lines = ["f " + ln[2:] if ln.startswith("l ") else ln
                                 for ln in text.splitlines()]
                        dest = Path(folder) / f"{i}_{j}_{src.name}"
                        dest.write_text("\n".join(lines) + "\n")
                        mesh["path"] = str(dest)
    if steps is not None:
        spec["num_steps"] = int(steps)
    out = Path(folder) / Path(path).name
    out.write_text(json.dumps(spec, indent=1))
    return out, spec


def run_theirs(binary, sim_path, spec, threads, timeout):
    """``(wall seconds, {object: centres (F, 3)}, evaluation count, mean us per evaluation)``."""
    folder = Path(sim_path).parent
    t0 = time.perf_counter()
    subprocess.run([binary, sim_path.name, str(threads)], cwd=folder, check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=timeout)
    wall = time.perf_counter() - t0
    paths = {}
    for obj in spec["objects"]:
        if not obj.get("is_dynamic", False):
            continue
        hits = glob.glob(str(folder / f"*__{obj['name']}__state.txt"))
        if len(hits) != 1:
            raise RuntimeError(f"their state file of {obj['name']!r}: found {hits}")
        with open(hits[0]) as fh:
            paths[obj["name"]] = np.array([[float(x) for x in line.split(";")[0].split(",")]
                                           for line in fh if line.strip()])
    times = []
    for f in glob.glob(str(folder / "*__times.txt")):
        with open(f) as fh:
            times += [float(x) for x in fh.read().split()]
    return wall, paths, len(times), (float(np.mean(times)) if times else float("nan"))


def run_ours(sim_path, threads, torques, timeout):
    """``(wall seconds, {body: centres (F, 3)}, evaluation count, simulate seconds)``."""
    out = Path(sim_path).parent / "ours"
    cmd = [sys.executable, "-m", "tracer", "simulate", str(sim_path), "-o", str(out),
           "--no-render", "--threads", str(threads), "--scheduler", "serial", "-q",
           "--torques", torques]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, cwd=ROOT, stdout=subprocess.DEVNULL, timeout=timeout)
    wall = time.perf_counter() - t0
    from tracer.sim.run import load_trajectory

    z = load_trajectory(out / "trajectory.npz")
    names = [str(n) for n in z["names"]]
    paths = {n: np.asarray(z["centers"])[:, i] for i, n in enumerate(names)
             if not bool(z["static"][i])}
    return wall, paths, int(np.sum(z["distance_evaluations"])), float(np.sum(z["seconds"]))


def scene_size(sim_path):
    """Diagonal of the bounding box of every body at its initial pose (scene units)."""
    from tracer.sim.simfile import load_simulation

    sim = load_simulation(sim_path)
    V = np.concatenate([b.world_vertices() for b in sim.bodies])
    return float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))


def compare(theirs, ours, size):
    """Largest path distance in % of ``size`` over every dynamic object, and the first step at
    which any passes :data:`SEPARATED` (None: never)."""
    worst = 0.0
    first = None
    for name, p in theirs.items():
        q = ours[name]
        n = min(len(p), len(q))
        d = np.linalg.norm(p[:n] - q[:n], axis=1) / size
        worst = max(worst, float(d.max()))
        over = np.flatnonzero(d > SEPARATED)
        if over.size and (first is None or over[0] < first):
            first = int(over[0])
    return 100.0 * worst, first


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="+", help="simulation files in the authors' format")
    ap.add_argument("--authors-bin", required=True, help="their rigid_body_simulator")
    ap.add_argument("--steps", type=int, help="run only this many steps (both)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--torques", choices=("split", "exact"), default="split",
                    help="ours: split (as theirs, default) or exact")
    ap.add_argument("--timeout", type=float, default=3600.0, help="seconds, per program")
    ap.add_argument("--keep", metavar="DIR", help="keep the runs' outputs in DIR")
    ap.add_argument("--json", metavar="OUT.json", help="also write the rows as JSON")
    args = ap.parse_args(argv)
    if not os.access(args.authors_bin, os.X_OK):
        ap.error(f"--authors-bin {args.authors_bin}: not an executable file")
    print(f"load average before: {os.getloadavg()[0]:.2f}", flush=True)
    rows = []
    for f in args.files:
        tmp = tempfile.mkdtemp(prefix="bench_authors_sim_")
        try:
            # warm-up: numba compiles (or loads from its cache) our kernels once, outside
            # the timing, as their binary is compiled before it runs. The warm-up is the
            # whole run: a kernel first needed at contact (the gradient kernels) would
            # otherwise be compiled inside the timed run (after an edit of its source file,
            # 48 s on ico_bowl)
            warm, _ = prepared_copy(f, tmp, args.steps)
            run_ours(warm, args.threads, args.torques, args.timeout)
            shutil.rmtree(Path(tmp) / "ours", ignore_errors=True)
            sim_path, spec = prepared_copy(f, tmp, args.steps)
            size = scene_size(sim_path)
            try:
                tw, tp, tn, tus = run_theirs(args.authors_bin, sim_path, spec, args.threads,
                                             args.timeout)
            except subprocess.TimeoutExpired:
                print(f"{f}: theirs did not finish in {args.timeout:.0f} s", flush=True)
                continue
            ow, op, on, osec = run_ours(sim_path, args.threads, args.torques, args.timeout)
            dev, first = compare(tp, op, size)
            row = {"file": os.path.relpath(f, ROOT) if Path(f).resolve().is_relative_to(ROOT)
                   else f, "steps": spec["num_steps"], "theirs_s": round(tw, 2),
                   "ours_s": round(ow, 2), "ratio": round(ow / tw, 4),
                   "theirs_evaluations": tn, "ours_evaluations": on,
                   "theirs_ms_per_evaluation": round(1e3 * tw / max(tn, 1), 3),
                   "ours_ms_per_evaluation": round(1e3 * ow / max(on, 1), 3),
                   "theirs_meshDistance_us": round(tus, 1),
                   "ours_simulate_s": round(osec, 2),
                   "max_path_deviation_pct": round(dev, 3), "separated_at_step": first,
                   "torques": args.torques}
            rows.append(row)
            print(json.dumps(row), flush=True)
            if args.keep:
                dest = Path(args.keep) / Path(f).stem
                shutil.copytree(tmp, dest, dirs_exist_ok=True)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    if rows:
        keys = ["file", "steps", "theirs_s", "ours_s", "ratio", "theirs_evaluations",
                "ours_evaluations", "theirs_ms_per_evaluation", "ours_ms_per_evaluation",
                "max_path_deviation_pct", "separated_at_step"]
        print("\n| " + " | ".join(keys) + " |")
        print("|" + "---|" * len(keys))
        for r in rows:
            print("| " + " | ".join(str(r[k]) for k in keys) + " |")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
