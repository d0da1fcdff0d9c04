"""Strided tasks of the batch kernels (``smoothdist.schedule``): results never depend on them."""

from pathlib import Path

import numba
import numpy as np
import pytest

from smoothdist import DataMesh, SmoothDistanceField
from smoothdist._kernels import query as q
from smoothdist.schedule import TASKS, parallel_tasks

BUNNY = Path(__file__).resolve().parents[2] / "scenes" / "data" / "bunny.off"


def test_one_task_per_thread():
    threads = numba.get_num_threads()
    assert parallel_tasks(10 ** 6) == min(threads, TASKS)
    assert parallel_tasks(1) == 1 and parallel_tasks(0) == 1


@pytest.fixture(scope="module")
def bunny():
    return SmoothDistanceField(DataMesh.load(BUNNY))


@pytest.mark.parametrize("ntasks", [1, 2, 3, 7, 64])
def test_batch_results_do_not_depend_on_the_tasks(bunny, ntasks):
    """The batch kernels fill every row (NaN before), with the same values whatever the number
    of strided tasks (47 chunks: 7 tasks do not divide them)."""
    rng = np.random.default_rng(3)
    lo, hi = bunny.bounds
    Q = lo + (hi - lo) * (1.4 * rng.random((3000, 3)) - 0.2)
    Q = Q[np.argsort(Q[:, 0])]                  # spatially sorted, as a grid would be
    n = len(Q)
    alpha, beta, S, wgrad_scale = bunny.kernel_args(200.0, 0.5)
    out = []
    for t in (1, ntasks):
        d, g = np.full(n, np.nan), np.full((n, 3), np.nan)
        nodes, leaves = np.empty(n, np.int64), np.empty(n, np.int64)
        q.smooth_distance_batch(bunny.tree, Q, alpha, beta, S, wgrad_scale, False, d, g, nodes, leaves,
                                0.0, t)
        e, eg, prim = np.full(n, np.nan), np.full((n, 3), np.nan), np.full(n, -1)
        q.exact_distance_batch(bunny.tree, Q, e, eg, prim, nodes.copy(), leaves.copy(), t)
        assert np.isfinite(d).all() and np.isfinite(e).all() and (prim >= 0).all()
        out.append((d, g, e, prim))
    for a, b in zip(*out):
        assert np.array_equal(a, b)
    # and the values are those of one query at a time
    for i in rng.choice(n, 20, replace=False):
        assert out[0][0][i] == bunny.smooth_distance(Q[i:i + 1], alpha=200.0, beta=0.5)[0][0]


@pytest.mark.parametrize("ntasks,threads", [(1, 1), (3, 2), (7, 3)])
def test_task_kernels_equal_the_prange_kernels(bunny, ntasks, threads, monkeypatch):
    """The serial task kernels run from Python threads (``schedule.run_tasks``, any split)
    give the ``prange`` kernels' values bit for bit (``tol = 0``), and so does the public
    ``smooth_distance`` / ``exact_distance`` on either side of ``TASK_BATCH`` (the exact
    tree, which rounds differently, kept out)."""
    from smoothdist import field as field_mod
    from smoothdist.field import TASK_BATCH
    from smoothdist.schedule import run_tasks

    rng = np.random.default_rng(5)
    lo, hi = bunny.bounds
    Q = lo + (hi - lo) * (1.4 * rng.random((700, 3)) - 0.2)
    n = len(Q)
    alpha, beta, S, wgrad_scale = bunny.kernel_args(200.0, 0.5, alpha_u=2000.0)

    def outs():
        return (np.full(n, np.nan), np.full((n, 3), np.nan), np.full(n, -1), np.full(n, -1),
                np.full(n, -1))

    ref, got = outs(), outs()
    q.smooth_distance_batch(bunny.tree, Q, alpha, beta, S, wgrad_scale, False, ref[0], ref[1], ref[3],
                            ref[4], 0.0, 2)
    run_tasks(lambda a, b: q.smooth_distance_tasks(bunny.tree, Q, alpha, beta, S, wgrad_scale, got[0],
                                                   got[1], got[3], got[4], 0, ntasks, a, b),
              ntasks, threads)
    assert all(np.array_equal(x, y) for x, y in zip(ref, got))
    ref, got = outs(), outs()
    q.exact_distance_batch(bunny.tree, Q, *ref, 2)
    run_tasks(lambda a, b: q.exact_distance_tasks(bunny.tree, Q, -1.0, *got, 0, ntasks, a, b),
              ntasks, threads)
    assert all(np.array_equal(x, y) for x, y in zip(ref, got))
    # the public methods: a small batch (task kernel) is the rows of a large one (prange)
    big = np.concatenate([Q] * (TASK_BATCH // n + 1))
    monkeypatch.setattr(field_mod, "EXACT_TREE_AFTER", 1e9)
    assert len(big) > TASK_BATCH >= n
    for f in (lambda X: bunny.smooth_distance(X, alpha=200.0, beta=0.5, alpha_u=2000.0),
              lambda X: SmoothDistanceField(bunny.mesh).exact_distance(X)):
        small, large = f(Q), f(big)
        assert all(np.array_equal(x, y[:n]) for x, y in zip(small, large))


@pytest.mark.parametrize("pool", [False, True])
def test_run_tasks_covers_every_task_once(pool):
    from smoothdist.schedule import run_tasks

    for ntasks in (1, 2, 5, 64):
        for threads in (1, 2, 3, 8):
            seen = []
            run_tasks(lambda a, b: seen.extend(range(a, b)), ntasks, threads, pool=pool)
            assert sorted(seen) == list(range(ntasks))

    def broken(a, b):
        if a > 0:
            raise RuntimeError("task failed")

    with pytest.raises(RuntimeError, match="task failed"):
        run_tasks(broken, 4, 2, pool=pool)


def test_largest_first_runs_every_item_once_and_raises_errors():
    from smoothdist.schedule import run_largest_first

    seen = []
    run_largest_first(lambda i, slot: seen.append((i, slot)), range(20), threads=3)
    assert sorted(i for i, _ in seen) == list(range(20))
    assert {slot for _, slot in seen} <= {1, 2, 3}

    def fail(i, slot):
        if i == 5:
            raise ValueError("item 5")

    with pytest.raises(ValueError, match="item 5"):
        run_largest_first(fail, range(10), threads=2)
