"""The warm-up (``smoothdist.warmup``, ``python -m smoothdist warmup``, ``tracer warmup``).

* The scheduler, on a throwaway jobs module: at most ``workers`` children at a time, a job
  waits for those it names, a failed job is reported with its error and the others still run.
* For real: after ``python -m smoothdist warmup --only smooth-distance`` into an empty cache, a
  new process's first ``smooth_distance`` compiles nothing.
* The command lines list their jobs and refuse unknown ones.
* The whole-mesh jobs reach every distance kernel ``MeshDistance`` can choose.
"""

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from smoothdist import warmup

ROOT = Path(__file__).resolve().parents[2]

TOY = textwrap.dedent('''
    import os, sys, time

    OUT = os.environ["TOY_OUT"]


    def stamp(name, seconds=0.0, fail=False, until=None):
        # until: a job whose file this one waits for (at most ``seconds``, or $TOY_WAIT), so
        # that "the other worker ran it meanwhile" does not depend on how loaded the machine is
        def job():
            start = time.time()
            limit = float(os.environ.get("TOY_WAIT", seconds))
            while until and not os.path.exists(os.path.join(OUT, until)):
                if time.time() - start > limit:
                    break
                time.sleep(0.01)
            time.sleep(0.0 if until else seconds)
            if fail:
                raise RuntimeError("toy job failed on purpose")
            with open(os.path.join(OUT, name), "w") as f:
                f.write(f"{start} {time.time()}")
        return job


    JOBS = {"slow": stamp("slow", 60.0, until="quick"), "after-slow": stamp("after-slow"),
            "broken": stamp("broken", fail=True), "quick": stamp("quick")}
    AFTER = {"after-slow": ("slow",), "unknown-waits": ("nothing",)}
''')


def _times(out, name):
    start, end = map(float, (out / name).read_text().split())
    return start, end


def test_jobs_wait_for_theirs_and_a_failure_is_reported(tmp_path, monkeypatch):
    (tmp_path / "toyjobs.py").write_text(TOY)
    out = tmp_path / "out"
    out.mkdir()
    monkeypatch.setenv("PYTHONPATH", str(tmp_path) + os.pathsep + os.environ.get("PYTHONPATH",
                                                                                   ""))
    monkeypatch.setenv("TOY_OUT", str(out))
    monkeypatch.syspath_prepend(str(tmp_path))
    jobs = warmup.jobs_of("toyjobs")
    assert [j[1] for j in jobs] == ["slow", "after-slow", "broken", "quick"]
    seen = []
    summary = warmup.run(jobs, workers=2, progress=lambda d, t, line: seen.append((d, t, line)))
    assert set(summary["jobs"]) == {"slow", "after-slow", "broken", "quick"}
    assert "toy job failed on purpose" in summary["jobs"]["broken"]["error"]
    assert all("error" not in summary["jobs"][n] for n in ("slow", "after-slow", "quick"))
    assert [d for d, _, _ in seen] == [1, 2, 3, 4] and all(t == 4 for _, t, _ in seen)
    # the waiting job started after the one it waits for ended
    assert _times(out, "after-slow")[0] >= _times(out, "slow")[1]
    # while it waited, a free worker took the next job
    assert _times(out, "quick")[0] < _times(out, "slow")[1]
    # one worker: one at a time (the slow job cannot see the quick one run meanwhile: it stops
    # waiting for it soon)
    for f in out.iterdir():
        f.unlink()
    monkeypatch.setenv("TOY_WAIT", "0.3")
    warmup.run([j for j in jobs if j[1] != "broken"], workers=1)
    spans = sorted(_times(out, n) for n in ("slow", "after-slow", "quick"))
    assert all(a[1] <= b[0] for a, b in zip(spans, spans[1:]))
    assert warmup.report(summary, jobs, out=open(os.devnull, "w")) == 1


def _env(cache):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["SMOOTHDIST_CACHE_DIR"] = str(cache)
    return env


@pytest.mark.slow
def test_after_the_warmup_a_first_call_compiles_nothing(tmp_path):
    env = _env(tmp_path / "cache")
    p = subprocess.run([sys.executable, "-m", "smoothdist", "warmup", "--only", "smooth-distance"],
                       env=env, capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    last = p.stderr.strip().splitlines()[-1]
    assert last.startswith("warmup: 1 of 1 jobs,") and str(tmp_path / "cache") in last
    compiled = int(last.split(" kernel specialisations")[0].rsplit(" ", 1)[-1])
    assert compiled > 0
    first = subprocess.run(
        [sys.executable, "-c", warmup.CHILD, "smoothdist.warmup", "smooth-distance"], env=env,
        capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert first.returncode == 0, first.stderr
    assert json.loads(first.stdout.strip().splitlines()[-1])["compiled"] == 0


def test_the_commands_list_their_jobs_and_refuse_unknown_ones(tmp_path):
    env = _env(tmp_path / "cache")
    lib = subprocess.run([sys.executable, "-m", "smoothdist", "warmup", "--list"], env=env,
                         capture_output=True, text=True, timeout=120)
    assert lib.returncode == 0, lib.stderr
    assert lib.stdout.split() == list(warmup.JOBS.keys())
    both = subprocess.run([sys.executable, "-m", "tracer", "warmup", "--list"], env=env,
                          capture_output=True, text=True, timeout=120)
    assert both.returncode == 0, both.stderr
    names = both.stdout.split()
    assert set(warmup.JOBS.keys()) <= set(names) and "render-mesh" in names
    bad = subprocess.run([sys.executable, "-m", "tracer", "warmup", "--only", "nope"], env=env,
                         capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and "unknown job(s) nope" in bad.stderr


def test_the_modules_jobs_are_taken_in_turn():
    """``tracer warmup`` starts the renderer's chain beside the library's (two cores), each
    module's own order kept; the waits still hold (the scheduler's)."""
    a = [("lib", n, ()) for n in ("a1", "a2", "a3")]
    b = [("tr", n, ()) for n in ("b1",)]
    assert [n for _, n, _ in warmup.interleaved([a, b])] == ["a1", "b1", "a2", "a3"]
    assert warmup.interleaved([]) == [] and warmup.interleaved([a]) == a
    from tracer import cli_warmup

    names = [n for _, n, _ in warmup.interleaved([warmup.jobs_of("smoothdist.warmup"),
                                                  warmup.jobs_of("tracer.cli_warmup")])]
    assert names[:2] == ["mesh-distance", "render-mesh"]
    assert set(names) == set(warmup.JOBS.keys()) | set(cli_warmup.JOBS.keys())
    # the exact offset surface and the tolerance's march: a job of their own, the edges
    # render (--tol) after it
    assert cli_warmup.AFTER["render-edges"] == ("render-exact",)


def test_the_whole_mesh_jobs_reach_every_distance_kernel():
    """Each (data kind, query kind) has a distance kernel of its own, compiled on first use: the
    warm-up's pairs (same kind, and mixed) must choose every one of them, the general kernel
    included (it once chose none after the one-kind kernels came)."""
    from smoothdist import whole_mesh
    from smoothdist._kernels import mesh_query

    pairs = [p for kind in ("triangles", "edges") for p in warmup.whole_mesh_pairs(kind, (0,))]
    pairs += warmup.mixed_kind_pairs((0,))
    mds = [whole_mesh.MeshDistance(d, q, alpha=50, alpha_q=50) for d, q in pairs]
    want = {*whole_mesh._ONE_KIND_KERNELS.values(), mesh_query.smooth_distance_primitive_tasks}
    assert {md._distance_kernel for md in mds} == want
    # the exact distance's: the one-kind pairs' and the general one (points, mixed meshes)
    mds += [whole_mesh.MeshDistance(d, q, alpha=50, alpha_q=50)
            for d, q in warmup.whole_mesh_pairs("points", (0,))]
    want = {*whole_mesh._ONE_KIND_EXACT.values(),
            (mesh_query.exact_distance_primitive_tasks, mesh_query.exact_distance_primitives)}
    assert {md._exact_kernels for md in mds} == want
