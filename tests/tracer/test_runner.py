"""Tests for tracer.runner: per-task results, retries, resume, and Dask execution.

The in-process tests are instant. The Dask tests share one 2-worker LocalCluster (module scope:
starting one costs seconds) and reach it through ``--scheduler ADDRESS``, exactly as a user's
cluster would be used; they check that a study gives the same rows there as in-process, that a
worker killed mid-study costs only its task, that a broken mesh is recorded and the rest
complete, and that a resumed study does not redo finished tasks.
"""

import csv
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from tracer import runner
from tracer.cli import main
from tracer.errors import CLIError
from tracer.studies import beta, grid

TESTS = Path(__file__).resolve().parents[1]
OCTOPUS = TESTS / "data" / "octopus_low.obj"
TREFOIL = TESTS / "data" / "trefoil.obj"
BETA_ARGS = ["--size", "24", "--betas", "0.5,1", "--alpha", "40", "--alpha-u", "300", "-q"]


def _rows(path):
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


# ----------------------------------------------------------------------------- task functions
# module level, so that Dask workers can import them by name
def square(task):
    if task.get("fail"):
        raise ValueError(f"task {task['x']} was told to fail")
    return {"x": task["x"], "y": task["x"] ** 2}


def flaky(task):
    """Fails (raises, or kills its worker process) the first time, then succeeds: the marker
    file remembers the first attempt across processes."""
    marker = Path(task["marker"])
    if not marker.exists():
        marker.write_text(str(os.getpid()))
        if task.get("kill"):
            os._exit(1)  # the worker process dies mid-task
        raise RuntimeError("first attempt fails")
    return {"x": task["x"], "y": task["x"] ** 2}


def _collect(fn, tasks, **kw):
    got, failed = {}, {}
    info = runner.run_study(fn, tasks, on_result=lambda t, r: got.__setitem__(t["key"], r),
                            on_failure=lambda t, e: failed.__setitem__(t["key"], e), quiet=True,
                            **kw)
    return got, failed, info


# ----------------------------------------------------------------------------- in-process
def test_serial_failure_is_recorded_and_the_rest_complete():
    tasks = [{"key": f"t{i}", "x": i, "fail": i == 2} for i in range(5)]
    got, failed, info = _collect(square, tasks, scheduler="serial")
    assert sorted(got) == ["t0", "t1", "t3", "t4"] and got["t3"]["y"] == 9
    assert list(failed) == ["t2"] and "told to fail" in failed["t2"]
    assert info.failed == [("t2", failed["t2"])] and info.done == 4
    assert got["t0"]["status"] == "ok" and got["t0"]["task_seconds"] >= 0


def test_serial_retry_of_a_task_that_raised(tmp_path):
    tasks = [{"key": "a", "x": 3, "marker": str(tmp_path / "a")}]
    got, failed, _ = _collect(flaky, tasks, scheduler="serial")
    assert got["a"]["y"] == 9 and not failed
    assert (tmp_path / "a").exists()  # the first attempt did fail


def test_bad_input_in_a_task_stops_the_study():
    def bad(task):
        raise CLIError("mesh file not found: x.obj")

    with pytest.raises(CLIError):
        _collect(bad, [{"key": "a"}, {"key": "b"}], scheduler="serial")


def test_task_log_appends_and_reads_back(tmp_path):
    log = runner.TaskLog(tmp_path / "r.csv", ["name", "value"], key="name")
    log.start()
    log.append({"name": "a", "value": 1.5, "status": "failed", "error": "boom"})
    log.append({"name": "b", "value": 2.0, "status": "ok"})
    log.append({"name": "a", "value": 1.25, "status": "ok"})  # a retried task
    with open(log.path, "a", encoding="utf-8") as fh:
        fh.write("c,3")  # an append cut short by an interruption
    rows = log.read()
    assert [(r["name"], r["value"], r["status"]) for r in rows] == [("b", "2", "ok"),
                                                                    ("a", "1.25", "ok")]
    assert log.done_keys() == {"a", "b"}
    assert list(rows[0]) == ["name", "value"] + runner.META_FIELDS


def test_choose_mode():
    assert runner.choose_mode("serial", None, 100, None) == "serial"
    assert runner.choose_mode("local", None, 1, None) == "serial"  # a single task
    assert runner.choose_mode("local", None, 9, 0.5) == "serial"  # tiny: no cluster start-up
    assert runner.choose_mode("local", 2, 9, 0.5) == "local"  # --workers asks for the cluster
    assert runner.choose_mode("tcp://h:8786", None, 1, 0.0) == "tcp://h:8786"


@pytest.mark.slow
def test_scheduler_argument_errors(tmp_path, capsys):
    out = tmp_path / "o"
    assert main(["bench-grid", str(TESTS / "data"), "-o", str(out), "--scheduler",
                 "tcp://127.0.0.1:1"]) == 2
    assert main(["bench-grid", str(TESTS / "data"), "-o", str(out), "--scheduler",
                 "nonsense"]) == 2
    assert main(["bench-grid", str(TESTS / "data"), "-o", str(out), "--scheduler", "serial",
                 "--workers", "2"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 3 and all(e.startswith("error:") for e in err)
    assert "cannot reach the Dask scheduler at tcp://127.0.0.1:1" in err[0]
    # the short connect timeout, not Dask's 30 s default
    assert f"waited at most {runner.CONNECT_TIMEOUT:g} s" in err[0]
    assert not out.exists()  # nothing was created


@pytest.mark.slow
def test_silent_scheduler_gives_up_after_the_timeout():
    """A server that accepts but never answers: the check gives up with 'no answer'."""
    pytest.importorskip("distributed")
    import socket

    with socket.socket() as srv:
        srv.bind(("127.0.0.1", 0))
        srv.listen(1)
        port = srv.getsockname()[1]
        with pytest.raises(CLIError, match=r"no answer.*waited at most 0.5 s"):
            runner.check_reachable(f"tcp://127.0.0.1:{port}", timeout=0.5)


# ----------------------------------------------------------------------------- Dask
@pytest.fixture(scope="module")
def cluster():
    pytest.importorskip("distributed")
    client, cl = runner.connect("local", workers=2)
    try:
        yield cl.scheduler_address
    finally:
        runner._shutdown(client, cl)


@pytest.mark.slow
def test_dask_rows_equal_serial_rows(cluster, tmp_path):
    serial, dask = tmp_path / "serial", tmp_path / "dask"
    assert main(["ablate-beta", str(OCTOPUS), "-o", str(serial), *BETA_ARGS,
                 "--scheduler", "serial"]) == 0
    assert main(["ablate-beta", str(OCTOPUS), "-o", str(dask), *BETA_ARGS,
                 "--scheduler", cluster]) == 0
    a, b = _rows(serial / beta.BETA_CSV), _rows(dask / beta.BETA_CSV)
    assert len(a) == 9 and [r["key"] for r in a] == [r["key"] for r in b]
    skip = set(beta.TIMING_FIELDS)
    for ra, rb in zip(a, b):
        assert {k: v for k, v in ra.items() if k not in skip} == \
            {k: v for k, v in rb.items() if k not in skip}
    assert {r["threads"] for r in b} == {"1"}  # one numba thread per worker process
    assert len({r["worker"] for r in b}) == 2  # both workers took part
    np.testing.assert_array_equal(np.load(serial / "cache" / "depth_edges_beta1.npy"),
                                  np.load(dask / "cache" / "depth_edges_beta1.npy"))


def test_dask_needs_no_default_client_and_keeps_the_users(cluster, monkeypatch):
    """``python -m tracer ... --scheduler ADDRESS`` runs in a process with no Dask client: the
    runner's own client is not made the default (a user's stays the default), so it must be
    used explicitly. Here the process's default clients are hidden, as in that process
    (``No clients found`` before the fix; tests/tracer/test_runner_cluster.py runs the real
    thing)."""
    import weakref

    import distributed
    import distributed.client

    monkeypatch.setattr(distributed.client, "_global_clients", weakref.WeakValueDictionary())
    with pytest.raises(ValueError, match="No clients found"):
        distributed.default_client()
    tasks = [{"key": f"t{i}", "x": i} for i in range(4)]
    got, failed, info = _collect(square, tasks, scheduler=cluster)
    assert not failed and [got[f"t{i}"]["y"] for i in range(4)] == [0, 1, 4, 9]
    assert info.workers == 2
    with pytest.raises(ValueError, match="No clients found"):  # none was left behind
        distributed.default_client()
    # a user's own default client is the default again after the study (while the study
    # waits for its results, its own client is the current one: the callbacks see that one)
    with distributed.Client(cluster, set_as_default=True) as user:
        seen = []
        got, failed, _ = _collect(
            square, tasks, scheduler=cluster,
            line=lambda t, r: seen.append(distributed.default_client()) or "")
        assert not failed and len(got) == 4
        assert distributed.default_client() is user
        assert seen and all(c is not user for c in seen)  # the study's client while it ran


def test_dask_killed_worker_and_failing_task(cluster, tmp_path):
    tasks = [{"key": f"k{i}", "x": i, "marker": str(tmp_path / f"m{i}"), "kill": i == 1}
             for i in range(4)]
    got, failed, info = _collect(flaky, tasks, scheduler=cluster)
    assert not failed and sorted(got) == ["k0", "k1", "k2", "k3"]
    assert [got[f"k{i}"]["y"] for i in range(4)] == [0, 1, 4, 9]
    assert (tmp_path / "m1").read_text() != got["k1"]["worker"].split(":")[1]  # it moved on
    tasks = [{"key": f"t{i}", "x": i, "fail": i == 2} for i in range(4)]
    got, failed, info = _collect(square, tasks, scheduler=cluster)
    assert sorted(got) == ["t0", "t1", "t3"] and list(failed) == ["t2"]
    assert "told to fail" in failed["t2"]


@pytest.mark.slow
def test_dask_grid_broken_mesh_and_resume(cluster, tmp_path):
    src = tmp_path / "meshes"
    src.mkdir()
    shutil.copy(OCTOPUS, src / "octopus.obj")
    shutil.copy(TREFOIL, src / "trefoil.obj")
    (src / "broken.obj").write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    (src / "empty.ply").write_bytes(b"")
    out = tmp_path / "bench"
    args = ["bench-grid", str(src), "-o", str(out), "--grid", "6", "-q", "--scheduler", cluster]
    assert main(args) == 0
    rows = {r["file"]: r for r in _rows(out / grid.BENCH_CSV)}
    assert sorted(rows) == ["broken.obj", "empty.ply", "octopus.obj", "trefoil.obj"]
    assert rows["broken.obj"]["status"] == rows["empty.ply"]["status"] == "skipped"
    assert "out of range" in rows["broken.obj"]["error"] and rows["empty.ply"]["error"]
    assert rows["octopus.obj"]["status"] == rows["trefoil.obj"]["status"] == "ok"
    assert int(rows["octopus.obj"]["nF"]) > 0 and rows["trefoil.obj"]["nF"] == ""
    assert float(rows["trefoil.obj"]["leaves_e"]) >= 1
    # resume: drop one finished row; only that mesh is measured again
    kept = [r for f, r in rows.items() if f != "octopus.obj"]
    with open(out / grid.BENCH_CSV, "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=list(kept[0]))
        w.writeheader()
        w.writerows(kept)
    assert main(args + ["--resume"]) == 0
    again = {r["file"]: r for r in _rows(out / grid.BENCH_CSV)}
    assert sorted(again) == sorted(rows)
    for f in ("trefoil.obj", "broken.obj"):  # untouched: same timing, same worker
        assert again[f] == rows[f]
    assert again["octopus.obj"]["nF"] == rows["octopus.obj"]["nF"]
    assert again["octopus.obj"]["leaves_f"] == rows["octopus.obj"]["leaves_f"]


def test_tracer_debug_shows_the_traceback_behind_an_error_line(monkeypatch, capsys, tmp_path):
    """A study's ``ValueError`` (Dask's 'No clients found' was one) is reported as one
    ``error:`` line; ``TRACER_DEBUG=1`` shows where it came from (issue 22: it showed none)."""
    from tracer.cli import main
    from tracer.studies import grid

    def boom(*args, **kwargs):
        raise ValueError("boom")

    monkeypatch.setattr(grid.runner, "run_study", boom)
    argv = ["bench-grid", "-o", str(tmp_path / "out"), "--grid", "2", "-q",
            "--scheduler", "serial"]
    monkeypatch.delenv("TRACER_DEBUG", raising=False)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.strip() == "error: boom"
    monkeypatch.setenv("TRACER_DEBUG", "1")
    argv[2] = str(tmp_path / "out2")
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback (most recent call last)" in err and "boom" in err
    assert err.strip().splitlines()[-1] == "error: boom"
