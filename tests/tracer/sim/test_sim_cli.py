"""``tracer simulate`` / ``tracer animate``: outputs, resume, and one-line errors with no output."""

import json
import os

import numpy as np
import pytest

from tracer.cli import main
from tracer.errors import SimFileError
from tracer.sim.simfile import load_simulation


def _sim(tmp_path, **changes):
    spec = {
        "name": "tiny",
        "dt": 0.01,
        "steps": 6,
        "gravity": [0, 0, -9.81],
        "camera": {"origin": [0, -3, 1.0], "dest": [0, 0, 0.2], "up": [0, 0, 1], "width": 32,
                   "height": 24, "every": 3},
        "bodies": [
            {"name": "floor", "primitive": {"type": "plane", "size": [2, 2], "resolution": 2},
             "alpha": 20, "static": True},
            {"name": "ball", "primitive": {"type": "sphere_points", "radius": 0.2, "count": 20},
             "alpha": 20, "position": [0, 0, 0.4], "velocity": [0.2, 0, -2.0]},
        ],
    }
    for k, v in changes.items():
        if v is None:
            spec.pop(k)
        else:
            spec[k] = v
    p = tmp_path / "tiny.json"
    p.write_text(json.dumps(spec))
    return p, spec


def _error_line(capsys):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: "), err
    return err[0]


def test_simulate_writes_the_required_trajectory(tmp_path, capsys):
    sim, _ = _sim(tmp_path)
    out = tmp_path / "run"
    assert main(["simulate", str(sim), "-o", str(out), "--no-render", "-q"]) == 0
    z = np.load(out / "trajectory.npz")
    F, B = 7, 2
    assert z["rotations"].shape == (F, B, 3, 3)
    assert z["translations"].shape == (F, B, 3)
    assert z["time"].shape == (F,) and z["min_exact_distance"].shape == (F,)
    np.testing.assert_allclose(z["time"], 0.01 * np.arange(F), atol=1e-12)
    assert (z["min_exact_distance"] > 0).all()
    assert z["ipm_iterations"][1:].sum() > 0          # it made contact
    # translations place the primitive's own coordinates: frame 0 is the file's position
    np.testing.assert_allclose(z["translations"][0, 1], [0, 0, 0.4], atol=1e-12)
    assert not (out / "frames").exists()


def test_resume_continues_exactly(tmp_path):
    sim, _ = _sim(tmp_path)
    a, b = tmp_path / "a", tmp_path / "b"
    assert main(["simulate", str(sim), "-o", str(a), "--no-render", "-q"]) == 0
    assert main(["simulate", str(sim), "-o", str(b), "--no-render", "-q", "--steps", "3"]) == 0
    assert main(["simulate", str(sim), "-o", str(b), "--no-render", "-q", "--resume"]) == 0
    za, zb = np.load(a / "trajectory.npz"), np.load(b / "trajectory.npz")
    for k in ("rotations", "centers", "velocities", "time"):
        np.testing.assert_array_equal(za[k], zb[k])


def test_simulate_renders_frames_mp4_and_gif_and_animate_rerenders(tmp_path):
    sim, _ = _sim(tmp_path, steps=3)
    out = tmp_path / "run"
    assert main(["simulate", str(sim), "-o", str(out), "-q"]) == 0
    frames = sorted(os.listdir(out / "frames"))
    assert frames == ["frame_00000.png", "frame_00001.png"]
    assert (out / "tiny.mp4").stat().st_size > 0 and (out / "tiny.gif").stat().st_size > 0
    import imageio.v3 as iio

    gif = iio.imread(out / "tiny.gif", index=None)
    assert gif.shape[0] == 2 and gif.shape[1:3] == (24, 32)
    movie = tmp_path / "m" / "movie.mp4"
    assert main(["animate", str(out / "trajectory.npz"), "-o", str(movie), "-q"]) == 0
    assert movie.stat().st_size > 0 and (tmp_path / "m" / "movie.gif").exists()
    a = iio.imread(out / "frames" / "frame_00001.png")
    b = iio.imread(tmp_path / "m" / "movie_frames" / "frame_00001.png")
    np.testing.assert_array_equal(a, b)
    small = tmp_path / "small.mp4"
    assert main(["animate", str(out / "trajectory.npz"), "-o", str(small), "--size", "16", "12",
                 "-q"]) == 0
    assert iio.imread(tmp_path / "small_frames" / "frame_00001.png").shape[:2] == (12, 16)
    assert main(["animate", str(out / "trajectory.npz"), "-o", str(tmp_path / "x.mp4"),
                 "--size", "0", "12", "-q"]) == 2
    assert not (tmp_path / "x.mp4").exists()



@pytest.mark.slow
def test_animate_frames_on_a_dask_cluster_equal_the_serial_frames(tmp_path):
    """Frames are independent tasks: a 2-worker local cluster renders the same PNGs."""
    pytest.importorskip("distributed")
    sim, _ = _sim(tmp_path, steps=4)
    out = tmp_path / "run"
    assert main(["simulate", str(sim), "-o", str(out), "--no-render", "-q"]) == 0
    traj = str(out / "trajectory.npz")
    assert main(["animate", traj, "-o", str(tmp_path / "s.mp4"), "--every", "1",
                 "--scheduler", "serial", "-q"]) == 0
    assert main(["animate", traj, "-o", str(tmp_path / "d.mp4"), "--every", "1",
                 "--workers", "2", "-q"]) == 0
    import imageio.v3 as iio

    names = sorted(os.listdir(tmp_path / "s_frames"))
    assert len(names) == 5 and names == sorted(os.listdir(tmp_path / "d_frames"))
    for n in names:
        np.testing.assert_array_equal(iio.imread(tmp_path / "s_frames" / n),
                                      iio.imread(tmp_path / "d_frames" / n))
    assert (tmp_path / "d.mp4").stat().st_size > 0 and (tmp_path / "d.gif").stat().st_size > 0
    assert main(["animate", traj, "-o", str(tmp_path / "x.mp4"), "--scheduler", "serial",
                 "--workers", "2", "-q"]) == 2


BAD = [
    ({"dt": 0}, "dt must be > 0"),
    ({"steps": 2.5}, "steps must be an integer"),
    ({"camera": None}, "missing the required key 'camera'"),
    ({"gravity": [0, 1]}, "gravity must be a list of 3 numbers"),
    ({"constraint": "hard"}, "constraint must be one of smooth, exact"),
    ({"bodies": [{"primitive": {"type": "point"}, "alpha": 1}]}, "at least 2 bodies"),
    ({"bodies": [{"primitive": {"type": "point"}, "alpha": 0},
                 {"primitive": {"type": "point"}, "alpha": 1}]}, "bodies[0].alpha must be > 0"),
    ({"bodies": [{"primitive": {"type": "point"}, "alpha": 1, "alhpa": 2},
                 {"primitive": {"type": "point"}, "alpha": 1}]}, "unknown key(s) 'alhpa'"),
    ({"bodies": [{"mesh": "nope.obj", "alpha": 1},
                 {"primitive": {"type": "point"}, "alpha": 1}]}, "bodies[0].mesh file not found"),
    ({"bodies": [{"primitive": {"type": "cube"}, "alpha": 1},
                 {"primitive": {"type": "point"}, "alpha": 1}]}, "bodies[0].primitive.type"),
    ({"bodies": [{"primitive": {"type": "point"}, "alpha": 1, "rotation": [[2, 0, 0], [0, 1, 0],
                                                                        [0, 0, 1]]},
                 {"primitive": {"type": "point"}, "alpha": 1}]}, "rotation must be a rotation"),
    ({"bodies": [{"primitive": {"type": "point"}, "alpha": 1, "crop": [[0, 0, 0], [0, 1, 1]]},
                 {"primitive": {"type": "point"}, "alpha": 1}]}, "bodies[0].crop must have"),
    ({"bodies": [{"primitive": {"type": "sphere_points"}, "alpha": 1,
                  "crop": [[5, 5, 5], [6, 6, 6]]},
                 {"primitive": {"type": "point"}, "alpha": 1}]}, "crop keeps no primitive"),
    ({"bodies": [{"primitive": {"type": "point"}, "alpha": 1, "static": True},
                 {"primitive": {"type": "point"}, "alpha": 1, "static": True}]}, "all static"),
]


@pytest.mark.parametrize("changes,message", BAD)
def test_bad_simulation_files_give_one_line_and_no_output(tmp_path, capsys, changes, message):
    sim, _ = _sim(tmp_path, **changes)
    out = tmp_path / "out"
    assert main(["simulate", str(sim), "-o", str(out), "--no-render"]) == 2
    line = _error_line(capsys)
    assert message in line and "tiny.json" in line
    assert not out.exists()
    with pytest.raises(SimFileError):
        load_simulation(sim)


def test_malformed_json_and_missing_file(tmp_path, capsys):
    p = tmp_path / "broken.json"
    p.write_text('{"dt": 0.01,')
    assert main(["simulate", str(p), "-o", str(tmp_path / "o")]) == 2
    assert "malformed JSON at line 1" in _error_line(capsys)
    assert main(["simulate", str(tmp_path / "none.json"), "-o", str(tmp_path / "o")]) == 2
    assert "simulation file not found" in _error_line(capsys)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("z", [0.0, 0.21])
def test_overlapping_initial_state_is_refused(tmp_path, capsys, z):
    """Geometry intersecting (z = 0) or only the smooth surfaces overlapping (z = 0.21)."""
    sim, spec = _sim(tmp_path)
    spec["bodies"][1]["position"] = [0, 0, z]
    sim.write_text(json.dumps(spec))
    out = tmp_path / "out"
    assert main(["simulate", str(sim), "-o", str(out)]) == 2
    line = _error_line(capsys)
    assert "overlap in the initial state" in line
    assert not out.exists()


def test_existing_output_is_kept_without_resume_or_overwrite(tmp_path, capsys):
    sim, _ = _sim(tmp_path, steps=1)
    out = tmp_path / "run"
    assert main(["simulate", str(sim), "-o", str(out), "--no-render", "-q"]) == 0
    before = (out / "trajectory.npz").read_bytes()
    assert main(["simulate", str(sim), "-o", str(out), "--no-render", "-q"]) == 2
    assert "output exists" in _error_line(capsys)
    assert (out / "trajectory.npz").read_bytes() == before


def test_auto_alpha_keeps_a_thin_body_close_to_the_floor(tmp_path, capsys):
    """``"alpha": "auto"`` in a simulation file (issue 22: refused before). Each drawn surface
    lies within a few percent of the thinnest body's thickness of its mesh, so a small ball
    resting on a plane shows no visible gap; the summary reports the gap. At the file's
    alpha 20 the same ball floats far above it (the reason for the rule)."""
    from tracer.sim import run
    from tracer.sim.bodies import AUTO_THICKNESS_OFFSET, thickness
    from smoothdist import SmoothDistanceField

    bodies = [
        {"name": "floor", "primitive": {"type": "plane", "size": [2, 2], "resolution": 2},
         "alpha": "auto", "static": True},
        {"name": "ball", "primitive": {"type": "icosphere", "radius": 0.1, "subdivisions": 1},
         "alpha": "auto", "position": [0, 0, 0.13]},
    ]
    sim_path, spec = _sim(tmp_path, bodies=bodies, steps=25)
    sim = load_simulation(sim_path)
    length = AUTO_THICKNESS_OFFSET * min(thickness(b.mesh) for b in sim.bodies)
    assert length == pytest.approx(AUTO_THICKNESS_OFFSET * 0.2, rel=0.05)
    for b in sim.bodies:
        assert b.alpha_u == b.alpha  # "off" by default, as for numbers
        off = SmoothDistanceField(b.mesh).offset_estimate(b.alpha, alpha_u=b.alpha)
        assert off <= length * 1.001
    out = tmp_path / "run"
    assert main(["simulate", str(sim_path), "-o", str(out), "--no-render"]) == 0
    err = capsys.readouterr().err
    assert "at the end floor and ball are" in err and "visible gap of" in err
    z = np.load(out / "trajectory.npz")
    assert z["ipm_iterations"][1:].sum() > 0  # it touched the floor
    gap = run.closest_gap(sim, run.build(sim)[0], z["centers"][-1], z["rotations"][-1])
    assert abs(gap["visible"]) <= 0.05 * gap["thickness"], gap
    # the same ball at alpha 20: its drawn surfaces float a visible fraction of it apart
    for b in bodies:
        b["alpha"] = 20
    (tmp_path / "a20").mkdir()
    sim20 = load_simulation(_sim(tmp_path / "a20", bodies=bodies)[0])
    drawn = sum(SmoothDistanceField(b.mesh).offset_estimate(20, alpha_u=20)
                for b in sim20.bodies)
    assert drawn > 0.3 * 0.2


def test_default_frame_size_is_640_by_360(tmp_path):
    cam = {"origin": [0, -3, 1.0], "dest": [0, 0, 0.2], "up": [0, 0, 1]}
    sim, _ = _sim(tmp_path, camera=cam)
    loaded = load_simulation(sim)
    assert (loaded.camera.width, loaded.camera.height) == (640, 360)


@pytest.mark.parametrize("bad, message", [
    ("automatic", 'bodies[1].alpha must be a number or "auto"'),
    (-1, "bodies[1].alpha must be > 0"),
])
def test_sim_alpha_values(tmp_path, bad, message):
    sim, spec = _sim(tmp_path)
    spec["bodies"][1]["alpha"] = bad
    sim.write_text(json.dumps(spec))
    with pytest.raises(SimFileError, match=message.replace("[", r"\[").replace("]", r"\]")):
        load_simulation(sim)


def test_shipped_ball_on_plane_draws_a_closed_ball():
    """Issue 35 item 5: the ball of ``scenes/simulations/ball_on_plane.json`` is drawn as
    one closed ball (120 points at alpha 40 were scattered dots above a full shadow): the
    smooth distance is <= 0 on the sphere the points sample, between the points too, and
    the drawn surface lies within a third of the radius outside it."""
    from pathlib import Path

    from smoothdist import SmoothDistanceField

    root = Path(__file__).resolve().parents[3]
    sim = load_simulation(str(root / "scenes" / "simulations" / "ball_on_plane.json"))
    ball = next(b for b in sim.bodies if b.name == "ball")
    field = SmoothDistanceField(ball.mesh)
    V = ball.mesh.V
    centre = V.mean(axis=0)
    radius = float(np.linalg.norm(V - centre, axis=1).mean())
    u = np.random.default_rng(0).normal(size=(500, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    on = centre + radius * u
    d = field.smooth_distance(on, alpha=ball.alpha, alpha_u=ball.alpha_u, beta=0.0).distance
    assert d.max() <= 0.0, d.max()
    out = centre + 1.34 * radius * u
    d = field.smooth_distance(out, alpha=ball.alpha, alpha_u=ball.alpha_u, beta=0.0).distance
    assert d.min() > 0.0, d.min()
