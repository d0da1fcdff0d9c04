"""``--scheduler ADDRESS`` against a Dask cluster started by hand, the way users run one.

A ``dask scheduler`` and two ``dask worker`` processes are started as separate programs on the
loopback interface (their own process groups, torn down by the fixture's finalizers also when
the test fails), and the study runs as ``python -m tracer ...`` in another process: that
process has no Dask client of its own except the one the study makes (the in-process tests of
``tests/tracer/test_runner.py`` run with a client already in the process, which hid a
``No clients found`` error here).
"""

import csv
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
MESHES = REPO / "scenes" / "data" / "meshes"
#: bounded waits (seconds)
START_TIMEOUT = 60.0
STUDY_TIMEOUT = 180.0


def _dask_command():
    """The ``dask`` command line next to this interpreter (the project's virtualenv)."""
    pytest.importorskip("distributed")
    exe = Path(sys.executable).parent / "dask"
    if exe.is_file():
        return str(exe)
    found = shutil.which("dask")
    if not found:
        pytest.skip("the 'dask' command line is not installed")
    return found


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _tail(path, n=25):
    try:
        return "\n".join(Path(path).read_text(errors="replace").splitlines()[-n:])
    except OSError:
        return ""


def _stop(proc):
    """Stop a process started in its own session: its whole process group (the worker's nanny
    and its worker process), SIGTERM then SIGKILL."""
    if proc.poll() is None:
        try:
            os.killpg(proc.pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
        try:
            proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            pass
    try:  # whatever is left of the group (also when the leader has already exited)
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    try:
        proc.wait(timeout=5)
    except subprocess.TimeoutExpired:
        pass


@pytest.fixture
def dask_cluster(request, tmp_path):
    """``(address, worker process ids, logs())`` of a scheduler and two one-thread workers
    on 127.0.0.1."""
    dask = _dask_command()
    logs = tmp_path / "logs"
    logs.mkdir()
    env = dict(os.environ)
    # workers find this checkout of the project, use one numba thread each (2-core machines)
    env["PYTHONPATH"] = os.pathsep.join([str(REPO)] + [p for p in
                                                       [env.get("PYTHONPATH")] if p])
    env["NUMBA_NUM_THREADS"] = "1"
    env.pop("TRACER_DEBUG", None)
    procs = []

    def start(name, args):
        log = open(logs / f"{name}.log", "wb")
        request.addfinalizer(log.close)
        proc = subprocess.Popen([dask, *args], cwd=REPO, env=env, stdin=subprocess.DEVNULL,
                                stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        procs.append((name, proc))
        request.addfinalizer(lambda: _stop(proc))
        return proc

    def logs_text():
        return "\n".join(f"--- {name} (exit {p.poll()}):\n{_tail(logs / f'{name}.log')}"
                         for name, p in procs)

    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    # loopback only, also the HTTP server (it runs even with --no-dashboard); the idle timeout
    # and the workers' death timeout end the processes should this test process be killed
    sched = start("scheduler", ["scheduler", "--host", "127.0.0.1", "--port", str(port),
                                "--no-dashboard", "--dashboard-address", "127.0.0.1:0",
                                "--idle-timeout", "600s"])
    for i in range(2):
        start(f"worker{i}", ["worker", address, "--nthreads", "1", "--host", "127.0.0.1",
                             "--no-dashboard", "--dashboard-address", "127.0.0.1:0",
                             "--name", f"worker{i}", "--death-timeout", "60s",
                             "--local-directory", str(tmp_path / f"scratch{i}")])

    from distributed import Client

    deadline = time.monotonic() + START_TIMEOUT
    while True:  # the scheduler listens
        if sched.poll() is not None:
            pytest.fail(f"the scheduler exited with status {sched.returncode}\n{logs_text()}")
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            break
        except OSError:
            if time.monotonic() > deadline:
                pytest.fail(f"the scheduler did not listen within {START_TIMEOUT:g} s\n"
                            f"{logs_text()}")
            time.sleep(0.2)
    # the workers have registered (set_as_default=False: this process keeps no default client)
    with Client(address, timeout="10s", set_as_default=False) as client:
        try:
            client.wait_for_workers(2, timeout=max(deadline - time.monotonic(), 1.0))
        except (TimeoutError, OSError) as exc:
            pytest.fail(f"the workers did not register within {START_TIMEOUT:g} s "
                        f"({type(exc).__name__})\n{logs_text()}")
        pids = {str(pid) for pid in client.run(os.getpid).values()}
    return address, pids, logs_text


@pytest.mark.slow
def test_bench_grid_on_a_cluster_started_by_hand(dask_cluster, tmp_path):
    address, worker_pids, logs_text = dask_cluster
    out = tmp_path / "bench"
    env = {k: v for k, v in os.environ.items() if k != "TRACER_DEBUG"}
    proc = subprocess.run([sys.executable, "-m", "tracer", "bench-grid", "scenes/data/meshes",
                           "-o", str(out), "--grid", "8", "--scheduler", address],
                          cwd=REPO, env=env, capture_output=True, text=True,
                          timeout=STUDY_TIMEOUT)
    assert proc.returncode == 0, (f"exit {proc.returncode}\nstdout:\n{proc.stdout}\n"
                                  f"stderr:\n{proc.stderr}\n{logs_text()}")
    assert "No clients found" not in proc.stderr + proc.stdout
    assert f"(3 task(s) Dask scheduler {address} (2 worker(s))" in proc.stdout
    with open(out / "bench_grid.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    meshes = sorted(p.name for p in MESHES.iterdir() if p.suffix == ".obj")
    assert len(meshes) == 3
    assert sorted(r["file"] for r in rows) == meshes  # one row per mesh
    assert all(r["status"] == "ok" and not r["error"] for r in rows), rows
    for r in rows:
        for L in "vef":
            assert float(r[f"leaves_{L}"]) >= 1.0
        # the tasks ran on the cluster's workers (one numba thread each)
        assert r["worker"].rsplit(":", 1)[1] in worker_pids, (r["worker"], worker_pids)
        assert r["threads"] == "1"
