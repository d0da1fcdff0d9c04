"""The mesh-distance benchmark's scenes (the paper's Table 3 sizes) and the demo script."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from smoothdist import DataMesh, MeshDistance

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "examples"))

import bench_mesh_distance as bench  # noqa: E402


def test_table3_sizes():
    """Generated geometry has the paper's primitive counts."""
    assert bench.ring_toss_points().shape == (12400, 3)
    V, E = bench.trefoil_100()
    assert E.shape == (100, 2) and DataMesh(V, E).edges.shape == (100, 2)
    V, E = bench.bowl_edges()
    assert DataMesh(V, E).edges.shape == (736, 2)
    V, E = bench.icosphere_edges()
    assert DataMesh(V, E).edges.shape == (120, 2)
    V, E = bench.slide_edges()
    assert DataMesh(V, E).edges.shape == (615, 2)
    V, F = bench.uv_sphere()
    m = DataMesh(V, F)
    assert m.triangles.shape == (960, 3)
    # a closed surface: every edge in exactly two triangles
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    _, counts = np.unique(E, axis=0, return_counts=True)
    assert np.all(counts == 2)


def test_resample_closed_polyline_is_even():
    t = np.linspace(0, 2 * np.pi, 50, endpoint=False)
    V = np.stack([np.cos(t), np.sin(t), 0 * t], axis=1)
    E = np.stack([np.arange(50), (np.arange(50) + 1) % 50], axis=1)
    W, F = bench.resample_closed_polyline(V, E, 20)
    L = np.linalg.norm(W[F[:, 1]] - W[F[:, 0]], axis=1)
    assert L.max() / L.min() < 1.05


def test_place_reaches_the_gap():
    V, E = bench.bowl_edges()
    Vq, Eq = bench.icosphere_edges()
    md = MeshDistance((V, E), (Vq, Eq), alpha=50.0, alpha_q=50.0)
    t = md.translation_at_gap(0.02, np.array([0.0, -1.0, 0.0]), np.array([0.0, 0.5, 0.0]))
    assert md.exact(t=t)[0] == pytest.approx(0.02, abs=1e-9)


@pytest.mark.slow
def test_benchmark_cli_rejects_bad_arguments():
    for args in (["--case", "nope"], ["--repeat", "0"], ["--tol", "x"], ["--tol", "-1"]):
        r = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_mesh_distance.py"),
                            *args], capture_output=True, text=True, cwd=ROOT)
        assert r.returncode == 2 and r.stderr.startswith("error:"), (args, r.stderr)
        assert "Traceback" not in r.stderr


def test_demo_renders_and_reports(tmp_path):
    import mesh_distance_demo as demo

    info = demo.run(24, str(tmp_path), gallery=str(tmp_path / "g.png"))
    assert (tmp_path / "mesh_distance.png").stat().st_size > 0
    assert (tmp_path / "g.png").stat().st_size > 0
    saved = json.loads((tmp_path / "mesh_distance.json").read_text())
    assert saved["exact_distance"] == pytest.approx(0.004, abs=1e-9)
    assert saved["smooth_distance"] <= saved["exact_distance"]
    # the sphere sits on the bunny's +x side: the gradient pushes it away, along +x
    assert saved["grad_sum"][0] > 0.5
    assert info["max_vertex_grad"] > 0


def test_demo_cli_rejects_bad_size(tmp_path):
    r = subprocess.run([sys.executable, str(ROOT / "examples" / "mesh_distance_demo.py"),
                        "--size", "3", "--out", str(tmp_path)], capture_output=True, text=True,
                       cwd=ROOT)
    assert r.returncode == 2 and r.stderr.startswith("error:")
    assert not any(tmp_path.iterdir())
