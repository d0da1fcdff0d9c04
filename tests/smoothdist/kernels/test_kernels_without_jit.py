"""The fast kernel tests again, with ``NUMBA_DISABLE_JIT=1``: the kernels run as plain Python.

Compiled kernels hide from coverage tools and give tracebacks without their own lines; run as
Python, they show both (as numba_celltree runs its suite). Python also runs them with other
number types: a numpy bool plus a numpy bool is their "or", not a count (the box bounds counted
separated axes that way until this test ran them), and ``njit`` returns the function itself,
with no ``py_func``. A chosen set of quick tests (small meshes, each well under a second as
Python) runs in one subprocess, so that the rest of the suite keeps its compiled kernels; the
whole set takes about 15 s of CPU time. Run it alone, with coverage, as in ``tests/README.md``.
"""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
K = "tests/smoothdist/kernels"

#: node ids, by kernel module; each a test that compares with an independent computation
CHOSEN = [
    # closest_point, closest_pair, box_distance
    f"{K}/test_closest_pair.py::test_random_pairs_match_reference",
    f"{K}/test_closest_pair.py::test_touching_and_crossing",
    f"{K}/test_closest_pair.py::test_degenerate_query_primitives",
    f"{K}/test_closest_pair.py::test_parallel_segments",
    f"{K}/test_closest_pair.py::test_segment_parallel_to_triangle",
    f"{K}/test_closest_pair.py::test_far_apart_pairs",
    f"{K}/test_closest_pair.py::test_box_lower_bound_never_overestimates[0]",
    f"{K}/test_closest_pair.py::test_box_lower_bound_never_overestimates[1]",
    f"{K}/test_closest_pair.py::test_box_bound_authors_failure_cases",
    # weights
    f"{K}/test_weights.py",
    # bvh
    f"{K}/test_bvh.py::test_tree_invariants[3-cube]",
    f"{K}/test_bvh.py::test_tree_invariants[3-mixed_mesh]",
    f"{K}/test_bvh.py::test_tree_invariants[8-trefoil]",
    f"{K}/test_bvh.py::test_leaf_size_gives_same_results[segment_star]",
    f"{K}/test_bvh_scale.py::test_point_cloud_tree_invariants",
    # traversal
    f"{K}/test_traversal.py::test_branch_and_bound_kind_finds_the_nearest_point",
    # query
    f"{K}/test_query.py::test_matches_naive_procedural[cube]",
    f"{K}/test_query.py::test_matches_naive_procedural[segment_star]",
    f"{K}/test_query.py::test_matches_naive_procedural[nonmanifold_mesh]",
    f"{K}/test_query.py::test_matches_naive_real_local[trefoil]",
    f"{K}/test_query.py::test_clamp_is_needed_on_nonmanifold_mesh",
    f"{K}/test_query.py::test_barnes_hut_monotone_procedural[circle]",
    f"{K}/test_query_tol.py::test_real_meshes_against_brute_force[3.0-trefoil]",
    # exact_query
    f"{K}/test_exact_query.py::test_fuzzed_mixed_meshes",
    f"{K}/test_exact_query.py::test_squared_distance_routines_match_brute_force",
    f"{K}/test_exact_query.py::test_ties_between_equidistant_primitives",
    f"{K}/test_exact_query.py::test_tree_and_queries_on_procedural_meshes[cube]",
    # mesh_query, mesh_moment, box_moment (through MeshDistance)
    "tests/smoothdist/test_whole_mesh.py::test_exact_distance_in_penetration",
    "tests/smoothdist/test_whole_mesh.py::test_gradient_matches_finite_differences[points-edges]",
    "tests/smoothdist/test_whole_mesh.py::test_gradient_matches_finite_differences[edges-edges]",
    "tests/smoothdist/test_whole_mesh.py::test_bounds_with_and_without_barnes_hut[edges-points]",
    "tests/smoothdist/test_whole_mesh.py::"
    "test_tolerance_pruning_stays_conservative[triangles-edges]",
    "tests/smoothdist/test_whole_mesh.py::test_rigid_transform_equals_moved_query",
]

#: run in the subprocess: refuse to pass if the kernels were compiled after all
CHECK_AND_RUN = """
import sys
import numba
import pytest
from smoothdist._kernels import query
assert numba.config.DISABLE_JIT, "NUMBA_DISABLE_JIT did not reach numba"
assert not hasattr(query.smooth_distance_point, "py_func"), "the kernels are compiled"
sys.exit(pytest.main(sys.argv[1:]))
"""


@pytest.mark.slow
def test_chosen_kernel_tests_pass_as_python():
    env = dict(os.environ, NUMBA_DISABLE_JIT="1",
               PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run(
        [sys.executable, "-c", CHECK_AND_RUN, "-q", "-p", "no:xdist", "-p", "no:cacheprovider",
         # the check imports smoothdist before pytest starts, so pytest cannot rewrite the
         # asserts of a plugin module that imports it (a warning, not a failure)
         "-W", "ignore::pytest.PytestAssertRewriteWarning", *CHOSEN],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out[-4000:]
    # every chosen test ran and passed: none skipped, deselected or missing
    summary = out.strip().splitlines()[-1]
    assert re.fullmatch(r"=* ?\d+ passed in [\d.]+s( \(.*\))? ?=*", summary), summary
    assert int(summary.split(" passed")[0].split()[-1]) >= len(CHOSEN)


def test_the_chosen_tests_exist():
    """Every chosen file and test function is still there (a rename must update the list)."""
    for node in CHOSEN:
        path, _, name = node.partition("::")
        assert (ROOT / path).is_file(), node
        if name:
            func = name.partition("[")[0]
            assert re.search(rf"^def {func}\(", (ROOT / path).read_text(), flags=re.M), node
