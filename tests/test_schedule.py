"""Items dealt out to threads (``smoothdist.schedule``), and kernels that deal them."""

from pathlib import Path

import numpy as np
import pytest

from smoothdist import DataMesh, SmoothDistanceField
from smoothdist import query as q
from smoothdist.schedule import deal, dealt

BUNNY = Path(__file__).resolve().parents[1] / "scenes" / "data" / "bunny.off"


def _order(n, threads):
    slots = deal(n, threads)
    assert slots % threads == 0 and n <= slots < n + threads
    order = np.array([dealt(j, slots, threads) for j in range(slots)], dtype=np.int64)
    return order, slots


@pytest.mark.parametrize("threads", [1, 2, 3, 4, 8])
@pytest.mark.parametrize("n", list(range(0, 20)) + [64, 1001, 4717])
def test_every_item_is_dealt_once(n, threads):
    order, _ = _order(n, threads)
    items = order[order < n]
    assert np.array_equal(np.sort(items), np.arange(n))


@pytest.mark.parametrize("n", [100, 1001, 4717, 65536])
@pytest.mark.parametrize("threads", [2, 3, 4, 8])
def test_each_thread_gets_every_threads_th_item(n, threads):
    """A ``prange`` gives thread ``k`` the slots ``[k s / T, (k + 1) s / T)``; dealt out, those
    hold items ``k, k + T, k + 2 T, ...`` in order (in list order the run is one part of the
    list only), so spatially sorted work is shared out evenly and each thread still walks
    through space."""
    order, slots = _order(n, threads)
    per = slots // threads
    for k in range(threads):
        run = order[k * per:(k + 1) * per]
        assert np.array_equal(run, np.arange(k, slots, threads))
        run = run[run < n]
        # every part of the list is in every thread's run
        counts = np.histogram(run, bins=threads, range=(0, n))[0]
        assert counts.min() >= run.size / threads - 2, (k, counts)


@pytest.fixture(scope="module")
def bunny():
    return SmoothDistanceField(DataMesh.load(BUNNY))


@pytest.mark.parametrize("threads", [1, 2, 3, 7])
def test_batch_results_do_not_depend_on_the_dealing(bunny, threads):
    """The batch kernels give every row the same values whatever the number of hands (the
    seeded exact search restarts its chain at every chunk)."""
    rng = np.random.default_rng(3)
    lo, hi = bunny.bounds
    Q = lo + (hi - lo) * (1.4 * rng.random((3000, 3)) - 0.2)
    Q = Q[np.argsort(Q[:, 0])]                  # spatially sorted, as a grid would be
    n = len(Q)
    alpha, beta, S, wgs = bunny.kernel_args(200.0, 0.5)
    out = []
    for t in (1, threads):
        d, g = np.empty(n), np.empty((n, 3))
        nodes, leaves = np.empty(n, np.int64), np.empty(n, np.int64)
        q.smooth_distance_batch(bunny.tree, Q, alpha, beta, S, wgs, False, d, g, nodes, leaves,
                                0.0, t)
        e, eg, prim = np.empty(n), np.empty((n, 3)), np.empty(n, np.int64)
        q.exact_distance_batch(bunny.tree, Q, e, eg, prim, nodes.copy(), leaves.copy(), t)
        out.append((d, g, e, prim))
    for a, b in zip(*out):
        assert np.array_equal(a, b)
    # and the values are those of one query at a time
    for i in rng.choice(n, 20, replace=False):
        assert out[0][0][i] == bunny.smooth_distance(Q[i:i + 1], alpha=200.0, beta=0.5)[0][0]
