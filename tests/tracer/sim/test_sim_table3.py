"""The paper's Table 3 simulations (``scenes/simulations/table3/``): every file loads, has the
paper's primitive counts, alphas and time steps, and the cheap ones run a few steps; the
committed meshes are what ``make_meshes.py`` makes; the LiDAR terrain generator.

The two terrain scenes build 6.6 million points (tens of seconds): their full load is one
``slow`` test; the quick tests check their files and the generator on a small terrain.
"""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from tracer.sim import primitives, run
from tracer.sim.simfile import load_simulation

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
TABLE3 = os.path.join(ROOT, "scenes", "simulations", "table3")

#: per file: dt, and per body (name, what the distance sees, primitive count, alpha, static);
#: the paper's Table 3 (bunny_bunny_plane holds its rows 5 and 6: the two bunnies and the plane)
EXPECTED = {
    "ico_bowl": (1 / 200, [("bowl", "edges", 736, 50, True), ("ico", "edges", 120, 50, False)]),
    "spikeball_bowl": (1 / 1000, [("bowl", "edges", 736, 50, True),
                                  ("spikeball", "mixed", 966, 20, False)]),
    "bunny_lidar": (1 / 100, [("terrain", "points", 6_600_000, 100, True),
                              ("bunny", "points", 3485, 20, False)]),
    "octopus_lidar": (1 / 100, [("terrain", "points", 6_600_000, 100, True),
                                ("octopus", "triangles", 4432, 1000, False)]),
    "bunny_bunny": (1 / 400, [("bunny1", "triangles", 6966, 200, False),
                              ("bunny2", "triangles", 6966, 200, False)]),
    "bunny_bunny_plane": (1 / 400, [("bunny1", "triangles", 6966, 200, False),
                                    ("bunny2", "triangles", 6966, 200, False),
                                    ("plane", "triangles", 800, 200, True)]),
    "sphere_slide": (1 / 100, [("slide", "edges", 615, 100, True),
                               ("sphere", "triangles", 960, 100, False)]),
    "trefoil_ringtoss": (1 / 200, [("ringtoss", "points", 12400, 20, True),
                                   ("trefoil", "edges", 100, 20, False)]),
}
TERRAIN = ("bunny_lidar", "octopus_lidar")
#: cheap enough to run a few steps in the quick suite (milliseconds to a few tenths per step)
RUN = ("ico_bowl", "spikeball_bowl", "bunny_bunny", "sphere_slide", "trefoil_ringtoss")
#: the paper's terrain has 6,591,087 points; ours must have at least this many
MIN_TERRAIN_POINTS = 6_500_000


def _path(name):
    return os.path.join(TABLE3, name + ".json")


def test_every_file_is_listed():
    names = sorted(os.path.splitext(f)[0] for f in os.listdir(TABLE3) if f.endswith(".json"))
    assert names == sorted(EXPECTED)


def _check(sim, name):
    dt, bodies = EXPECTED[name]
    assert sim.dt == pytest.approx(dt)
    assert [b.name for b in sim.bodies] == [b[0] for b in bodies]
    for b, (_, kind, count, alpha, static) in zip(sim.bodies, bodies):
        assert b.mesh.kind == kind, b.name
        assert b.mesh.num_primitives == count, b.name
        assert b.alpha == alpha and b.static == static, b.name


@pytest.mark.parametrize("name", [n for n in EXPECTED if n not in TERRAIN])
def test_loads_with_the_papers_counts(name):
    sim = load_simulation(_path(name))
    _check(sim, name)
    if name == "spikeball_bowl":      # a sphere of triangles plus spikes as edges, one body
        m = sim.bodies[1].mesh
        assert (len(m.triangles), len(m.edges)) == (960, 6)


@pytest.mark.parametrize("name", RUN)
def test_cheap_scenes_run(name, tmp_path):
    sim = load_simulation(_path(name))
    out = tmp_path / "trajectory.npz"
    run.simulate(sim, str(out), steps=3)
    z = run.load_trajectory(str(out))
    assert len(z["time"]) == 4
    assert np.min(z["min_exact_distance"]) > 0
    moving = [k for k, b in enumerate(sim.bodies) if not b.static]
    assert np.all(np.linalg.norm(z["centers"][-1, moving] - z["centers"][0, moving], axis=1) > 0)


@pytest.mark.parametrize("name", TERRAIN)
def test_terrain_files(name):
    """Without building the terrain: the generator's parameters give at least 6.5 million
    points (``tile points x copies x tiles``), and the tile is the shipped one."""
    with open(_path(name)) as fh:
        spec = json.load(fh)
    terrain = spec["bodies"][0]["primitive"]
    assert terrain["type"] == "lidar_terrain"
    tile = os.path.normpath(os.path.join(TABLE3, terrain["path"]))
    assert tile == os.path.normpath(primitives.AUTZEN_TILE)
    with open(tile, "rb") as fh:
        header = fh.read(400).split(b"end_header")[0].decode()
    n = int(header.split("element vertex")[1].split()[0])
    assert n == 110_000
    count = n * terrain["copies"] * terrain["tiles"][0] * terrain["tiles"][1]
    assert count == 6_600_000 >= MIN_TERRAIN_POINTS
    assert spec["dt"] == 0.01 and spec["bodies"][0]["alpha"] == 100


def test_terrain_scene_builds(tmp_path):
    """The terrain scenes load through the generator: the bunny scene with 3 copies of the tile
    instead of 60 (the full 6.6 million points take 30-60 s and about 1 GB here; their count is
    checked from the parameters in ``test_terrain_files``, and ``tracer reproduce`` builds
    them), and the octopus scene's terrain is the same generator call."""
    with open(_path("bunny_lidar")) as fh:
        spec = json.load(fh)
    terrain = spec["bodies"][0]["primitive"]
    terrain["copies"] = 3
    terrain["path"] = os.path.normpath(os.path.join(TABLE3, terrain["path"]))
    spec["bodies"][1]["mesh"] = os.path.join(TABLE3, spec["bodies"][1]["mesh"])
    small = tmp_path / "bunny_lidar_small.json"
    small.write_text(json.dumps(spec))
    sim = load_simulation(str(small))
    ground, bunny = sim.bodies
    assert ground.mesh.kind == "points" and ground.mesh.num_primitives == 3 * 110_000
    assert ground.static and ground.alpha == 100
    assert (bunny.mesh.kind, bunny.mesh.num_primitives, bunny.alpha) == ("points", 3485, 20)
    # the copies are jittered, not stacked: no two points coincide
    V = ground.mesh.V
    assert len(np.unique(V.round(9), axis=0)) == len(V)
    # the octopus scene: the same terrain parameters, so only its octopus is checked here
    with open(_path("octopus_lidar")) as fh:
        other = json.load(fh)
    with open(_path("bunny_lidar")) as fh:
        assert other["bodies"][0] == json.load(fh)["bodies"][0]


def test_octopus_body():
    """The octopus scene's body (its terrain is checked above): 4,432 closed triangles."""
    from smoothdist import DataMesh

    m = DataMesh.load(os.path.join(TABLE3, "meshes", "octopus_4432.obj"))
    assert m.kind == "triangles" and m.num_primitives == 4432
    E = np.sort(np.concatenate([m.triangles[:, [0, 1]], m.triangles[:, [1, 2]],
                                m.triangles[:, [2, 0]]]), axis=1)
    _, counts = np.unique(E, axis=0, return_counts=True)
    assert np.all(counts == 2)                     # closed, manifold
    assert m.V.shape[0] - len(counts) + len(m.triangles) == 2   # a sphere's Euler number


@pytest.mark.slow
def test_make_meshes_is_reproducible():
    r = subprocess.run([sys.executable, os.path.join(TABLE3, "make_meshes.py"), "--check"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr


def test_lidar_terrain_generator():
    n = 110_000
    two = primitives.lidar_terrain(copies=1, tiles=(2, 1), scale=1.0)
    seam = 2 * n - len(two)                            # tile points on the shared edge, once
    assert 1 <= seam <= 100
    # mirrored: the second copy is the first reflected about their common edge (x = 0)
    left, right = two[two[:, 0] < 0] * [-1, 1, 1], two[two[:, 0] > 0]
    assert len(left) == len(right) == n - seam
    order = lambda P: P[np.lexsort(np.round(P, 6).T)]  # noqa: E731
    assert np.allclose(order(left), order(right), atol=1e-9)
    # one tile, the tile's size at scale 1: centred in x and y, z from the lowest point
    one = primitives.lidar_terrain(copies=1, scale=1.0)
    assert len(one) == n
    assert np.allclose(one.min(axis=0)[:2], -one.max(axis=0)[:2])
    assert one[:, 2].min() == 0.0
    tile = primitives.DataMesh.load(primitives.AUTZEN_TILE).V
    assert np.allclose(np.ptp(one, axis=0), np.ptp(tile, axis=0))
    # densified: the tile's points then the jittered copies, reproducible from the seed
    dense = primitives.lidar_terrain(copies=3, seed=3, z_scale=2.0)
    assert len(dense) == 3 * n
    assert np.allclose(dense[::3] * [1, 1, 0.5], 0.05 * one)
    assert np.array_equal(dense, primitives.lidar_terrain(copies=3, seed=3, z_scale=2.0))
    assert not np.array_equal(dense, primitives.lidar_terrain(copies=3, seed=4, z_scale=2.0))
    jitter = (dense.reshape(n, 3, 3)[:, 1:] - dense[::3, None]) / 0.05
    assert np.std(jitter[..., 0]) == pytest.approx(1.0, rel=0.02)       # 1 ft horizontally
    assert np.std(jitter[..., 2]) == pytest.approx(2 * 0.1, rel=0.02)   # 0.1 ft, z_scale 2
    with pytest.raises(ValueError):
        primitives.lidar_terrain(copies=0)


def test_bench_sim_finds_table3(capsys):
    sys.path.insert(0, os.path.join(ROOT, "benchmarks"))
    try:
        import bench_sim
    finally:
        sys.path.pop(0)
    names = [n for n, _ in bench_sim.scene_files(table3=True)]
    assert {f"table3/{n}" for n in EXPECTED} <= set(names)
    assert not any(n.startswith("table3/") for n, _ in bench_sim.scene_files())
    bench_sim.main(["--table3", "--steps", "2", "table3/trefoil_ringtoss"])
    out = capsys.readouterr().out
    assert "12400 points + 100 edges" in out and "| table3/trefoil_ringtoss | 2 |" in out
    with pytest.raises(SystemExit):
        bench_sim.main(["table3/trefoil_ringtoss"])          # Table 3 scenes need --table3


def test_make_clips_end_to_end(tmp_path):
    """``make_clips.py`` on a short run of one scene: simulates, renders the frames, writes the
    MP4, the GIF, the README's small GIF and a JSON row whose frame count matches the PNGs."""
    from PIL import Image

    out, small, rows = tmp_path / "clips", tmp_path / "readme", tmp_path / "rows.json"
    proc = subprocess.run(
        [sys.executable, os.path.join(TABLE3, "make_clips.py"), "trefoil_ringtoss", "--steps", "4",
         "--frames", "3", "--size", "48", "32", "--readme-size", "24", "16", "-o", str(out),
         "--readme", str(small), "--json", str(rows)],
        capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    scene = out / "trefoil_ringtoss"
    pngs = sorted((scene / "trefoil_ringtoss_frames").glob("*.png"))
    [row] = json.loads(rows.read_text())
    assert row["steps"] == 4 and row["frames"] == len(pngs) == 3
    assert Image.open(pngs[0]).size == (48, 32)
    assert (scene / "trefoil_ringtoss.mp4").stat().st_size > 0
    gif = Image.open(small / "trefoil_ringtoss.gif")
    # (Pillow merges consecutive frames that came out identical at this size)
    assert gif.size == (24, 16) and 1 <= gif.n_frames <= 3
    assert row["s_per_frame_median"] > 0


def test_make_clips_refuses_an_unknown_scene():
    proc = subprocess.run([sys.executable, os.path.join(TABLE3, "make_clips.py"), "no_such"],
                          capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert proc.returncode == 2 and "unknown scene" in proc.stderr
