"""The contact-solver example (examples/plot_contact_solver.py) at a small size: the log
barrier on ``MeshDistance`` keeps the box out of the floor on the whole path, stops within the
error budget of contact, and its torque lays a tilted box flat (issue 47, item 4).

The checks are geometric, not stored values: the exact gap (an independent branch-and-bound
search) must stay > 0 on every accepted placement, the smooth distance must lie within
``[gap - e, gap]`` at rest, and the tilt must fall (a torque of the wrong sign leaves the box
at 13 degrees). The paper's metric gradient would pass here: at the alpha ``within`` chooses
(about 3,000) its weights' term, divided by alpha, is too small to matter.
"""
import runpy
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "plot_contact_solver.py"


@pytest.fixture(scope="module")
def example():
    """The example's namespace (running it solves both placements at its own size)."""
    return runpy.run_path(str(EXAMPLE))


@pytest.mark.parametrize("tilt", [0.0, 30.0])
def test_barrier_solver_rests_on_the_floor(example, tilt):
    e = 0.01
    r = example["solve"](tilt, e=e, rounds=3, steps=30, n=10)
    assert r["steps"] > 10
    assert r["infeasible"] >= 0 and r["backtracks"] >= 0
    assert r["min_gap"] > 0.0                     # never through the floor on the path
    assert r["min_d_hat"] > 0.0
    assert 0.0 < r["d_hat"] <= r["gap"] <= r["d_hat"] + e
    assert r["gap"] < e                           # pulled into contact, not hovering
    assert r["t"][2] < 0.2                        # from 0.45 down onto the floor
    assert r["tilt_deg"] < 10.0                   # laid (nearly) flat on the bumps


def test_example_script_reports_both_placements(example):
    res = example["results"]
    assert set(res) == {0.0, 30.0}
    for r in res.values():
        assert r["min_gap"] > 0 and r["gap"] < 0.005 and r["tilt_deg"] < 10.0
