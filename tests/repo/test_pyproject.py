"""Dependencies: the library needs numpy and numba only; the tracer's parts are extras.

Each check runs in a fresh interpreter in which the packages an install without the extra would
lack cannot be imported (a meta-path finder refuses them), so a module that imports one of them
at the top, or on the way of a command that should not need it, fails here.

Every command names the optional packages it will import (its ``needs``, checked by
``tracer.cli`` before any work): in-process tests hide one of them (``sys.modules[name] = None``,
as for a package that is not installed) and check that the command stops with the one-line
error before its ``run`` starts, and that a command runs without the packages it does not
need.
"""

import importlib
import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
#: what each extra adds (the top-level module names)
TRACER = ("PIL", "trimesh")
SIM = ("scipy", "imageio", "imageio_ffmpeg")
STUDIES = ("matplotlib", "distributed", "dask", "pyvista", "vtk", "vtkmodules")
GPU = ("numba_cuda", "cuda")

PRELUDE = textwrap.dedent("""\
    import sys
    BLOCKED = set({blocked!r})

    class _Refuse:
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in BLOCKED:
                raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
            return None

    sys.meta_path.insert(0, _Refuse())
""")


def _run(code, blocked, *args):
    script = PRELUDE.format(blocked=tuple(blocked)) + textwrap.dedent(code)
    return subprocess.run([sys.executable, "-c", script, *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=600)


def test_the_library_alone_needs_numpy_and_numba():
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    names = sorted(d.split(">")[0].split("=")[0].split("<")[0].strip()
                   for d in meta["dependencies"])
    assert names == ["numba", "numpy"]
    extras = meta["optional-dependencies"]
    assert {"tracer", "sim", "studies", "all", "docs", "test"} <= set(extras)
    # .ci/run (the README's test command) installs the test extra, which holds everything
    assert any("all" in d for d in extras["test"])
    # the GPU path: numba-cuda, in the test extra too (its simulator runs the CUDA kernels)
    assert [d.split(">")[0] for d in extras["gpu"]] == ["numba-cuda"]
    assert any("gpu" in d for d in extras["test"])


@pytest.mark.slow
def test_smoothdist_works_without_any_extra():
    p = _run("""
        import numpy as np
        import smoothdist as sd
        V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
        F = np.array([[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]])
        d, g = sd.smooth_distance([[0.2, 0.2, 2.0]], V, F, alpha=10.0)
        e, _ = sd.exact_distance([[0.2, 0.2, 2.0]], V, F)
        m = sd.load_mesh("scenes/data/bunny.off")
        c = sd.load_mesh("scenes/data/curves/trefoil.obj")
        md = sd.mesh_distance(V, F, V + [0, 0, 3.0], F, alpha=10.0, alpha_q=10.0)[0]
        f = sd.SmoothDistanceField(m.as_kind("points"))
        f.auto_alpha()
        bad = [k for k in sys.modules if k.split(".")[0] in BLOCKED]
        assert not bad, bad
        print("ok", float(d[0]) <= float(e[0]), m.num_primitives > 0, md > 0)
    """, TRACER + SIM + STUDIES + GPU)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split() == ["ok", "True", "True", "True"]


def test_device_cuda_without_the_gpu_extra_says_what_to_install():
    p = _run("""
        import os
        os.environ.pop("NUMBA_ENABLE_CUDASIM", None)
        import numpy as np
        import smoothdist as sd
        from smoothdist.cuda import CudaUnavailable
        f = sd.SmoothDistanceField(np.eye(3))
        try:
            f.smooth_distance(np.zeros((1, 3)), alpha=10.0, device="cuda")
        except CudaUnavailable as exc:
            print(exc)
    """, GPU)
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == ("device 'cuda' needs numba-cuda: pip install numba-cuda (or the "
                                "gpu extra in the clone: pip install -e '.[gpu]')")


def test_a_ply_file_without_trimesh_says_what_to_install():
    p = _run("""
        import smoothdist as sd
        try:
            sd.load_mesh("scenes/data/pointclouds/scan_guardian_lion_points.ply")
        except ImportError as exc:
            print("ImportError:", exc)
    """, TRACER + SIM + STUDIES)
    assert p.returncode == 0, p.stderr
    assert "ImportError:" in p.stdout and "pip install" in p.stdout and "trimesh" in p.stdout


@pytest.mark.parametrize("scene", ["bunny", "bunny_points"])  # the README's first
def test_tracer_render_needs_only_the_tracer_extra(tmp_path, scene):
    out = tmp_path / "b.png"
    p = _run("""
        import runpy
        sys.argv = ["tracer"] + sys.argv[1:]
        runpy.run_module("tracer", run_name="__main__")
    """, SIM + STUDIES + GPU, "render", f"scenes/{scene}.json", "--size", "16", "16",
        "-o", str(out), "-q")
    assert p.returncode == 0, p.stderr
    assert out.stat().st_size > 0


@pytest.mark.parametrize("argv, missing", [
    (["render", "scenes/bunny_points.json", "--size", "8", "8", "-o", "{tmp}/x.png"], "PIL"),
    (["compare", "scenes/torus.json", "--grid", "8", "--size", "8", "8", "-o", "{tmp}/c"],
     "pyvista"),
    (["bench-grid", "-o", "{tmp}/g", "--grid", "4", "--scheduler", "tcp://127.0.0.1:9"],
     "distributed"),
])
@pytest.mark.slow
def test_a_missing_extra_is_one_line_naming_the_package(tmp_path, argv, missing):
    p = _run("""
        import runpy
        sys.argv = ["tracer"] + sys.argv[1:]
        runpy.run_module("tracer", run_name="__main__")
    """, (missing,), *[a.replace("{tmp}", str(tmp_path)) for a in argv])
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2, p.stderr
    assert len(lines) == 1 and lines[0].startswith("error: "), p.stderr
    assert "pip install" in lines[0] and "smoothdist[" in lines[0], lines[0]
    assert "Traceback" not in p.stderr


# ---------------------------------------------------------------- extras checked before any work
#: (argv, the package hidden, its name in the error line); ``{tmp}`` is a scratch folder
MISSING = [
    (["render", "scenes/data/meshes/torus.obj", "-o", "{tmp}/t.png"], "PIL", "pillow"),
    (["render", "scenes/bunny_points.json", "--steps-png", "{tmp}/s.png", "-o", "{tmp}/b.png"],
     "matplotlib", "matplotlib"),
    (["render", "scenes/data/pointclouds/scan_guardian_lion_points.ply", "-o", "{tmp}/l.png"],
     "trimesh", "trimesh"),
    (["render", "scenes/lion_points.json", "-o", "{tmp}/l.png"], "trimesh", "trimesh"),
    (["compare", "scenes/torus.json", "-o", "{tmp}/c"], "pyvista", "pyvista"),
    (["diff", "{tmp}/a.png", "{tmp}/b.png"], "matplotlib", "matplotlib"),
    (["ablate-beta", "scenes/data/bunny.off", "-o", "{tmp}/b"], "matplotlib", "matplotlib"),
    (["ablate-alpha", "underestimate", "-o", "{tmp}/a"], "trimesh", "trimesh"),
    (["bench-grid", "-o", "{tmp}/g", "--workers", "2"], "distributed", "distributed"),
    (["bh-switch", "-o", "{tmp}/h"], "PIL", "pillow"),
    (["simulate", "scenes/simulations/ball_on_plane.json", "-o", "{tmp}/s"], "scipy", "scipy"),
    (["simulate", "scenes/simulations/ball_on_plane.json", "-o", "{tmp}/s"], "imageio_ffmpeg",
     "imageio-ffmpeg"),
    (["animate", "{tmp}/t.npz", "-o", "{tmp}/m.mp4"], "imageio", "imageio"),
    (["reproduce", "--smoke", "--out", "{tmp}/r"], "matplotlib", "matplotlib"),
]
#: (argv, packages hidden): a command whose own packages are there runs without the others
ENOUGH = [
    (["render", "scenes/bunny_points.json", "-o", "{tmp}/b.png"], ("trimesh",) + SIM + STUDIES),
    (["render", "scenes/data/meshes/torus.obj", "-o", "{tmp}/t.png"], ("trimesh",) + STUDIES),
    (["simulate", "scenes/simulations/ball_on_plane.json", "-o", "{tmp}/s", "--no-render"],
     TRACER + STUDIES + ("imageio", "imageio_ffmpeg")),
    (["ablate-alpha", "metric", "-o", "{tmp}/a"], ("trimesh", "distributed", "dask") + SIM),
    (["reproduce", "--report-only", "--out", "{tmp}/r"], TRACER + SIM + STUDIES),
]


def _main_without(monkeypatch, hidden, argv, tmp_path):
    """``tracer.cli.main(argv)`` in this process with the packages ``hidden`` as an install
    without them has them (``import`` fails, ``find_spec`` finds nothing) and the command's
    ``run`` replaced by a recorder; returns ``(status, runs)``."""
    from tracer import cli

    monkeypatch.chdir(ROOT)
    module = importlib.import_module(cli.COMMANDS[argv[0]])
    runs = []
    monkeypatch.setattr(module, "run", lambda args: runs.append(args.command) or 0)
    for name in hidden:
        monkeypatch.setitem(sys.modules, name, None)
    return cli.main([a.replace("{tmp}", str(tmp_path)) for a in argv]), runs


@pytest.mark.parametrize("argv, hidden, package", MISSING,
                         ids=[f"{i}-{a[0]}-{h}" for i, (a, h, _) in enumerate(MISSING)])
def test_a_missing_extra_stops_the_command_before_it_starts(monkeypatch, capsys, tmp_path,
                                                           argv, hidden, package):
    from tracer import cli

    status, runs = _main_without(monkeypatch, [hidden], argv, tmp_path)
    lines = capsys.readouterr().err.strip().splitlines()
    extra = cli.EXTRA_OF[hidden][1]
    assert (status, runs) == (2, []), lines
    assert lines == [f"error: this command needs {package}, which is not installed (pip install "
                     f"'smoothdist[{extra}]', or 'smoothdist[all]' for every command)"]


def test_the_message_is_the_one_of_a_failed_import(monkeypatch, capsys, tmp_path):
    from tracer import cli

    status, _ = _main_without(monkeypatch, ["PIL"], MISSING[0][0], tmp_path)
    exc = ModuleNotFoundError("No module named 'PIL'", name="PIL")
    assert status == 2 and capsys.readouterr().err == f"error: {cli._missing_package(exc)}\n"


@pytest.mark.parametrize("argv, hidden", ENOUGH, ids=[" ".join(a[:2]) for a, _ in ENOUGH])
def test_a_command_runs_without_the_extras_it_does_not_need(monkeypatch, tmp_path, argv,
                                                            hidden):
    status, runs = _main_without(monkeypatch, hidden, argv, tmp_path)
    assert (status, runs) == (0, [argv[0]])


def test_installed_looks_without_importing(monkeypatch, tmp_path):
    from tracer import cli

    (tmp_path / "smoothdist_probe_pkg.py").write_text("raise AssertionError('imported')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    assert cli.installed("smoothdist_probe_pkg") and not cli.installed("no_such_package_here")
    assert "smoothdist_probe_pkg" not in sys.modules
    monkeypatch.setitem(sys.modules, "numpy", None)  # an import of it fails
    assert not cli.installed("numpy")

    class Refuse:
        def find_spec(self, name, path=None, target=None):
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)

    monkeypatch.setattr(sys, "meta_path", [Refuse()] + sys.meta_path)
    assert not cli.installed("smoothdist_probe_pkg")


def test_every_experiment_of_reproduce_says_what_it_needs():
    from tracer import cli
    from tracer.reproduce.experiments import EXPERIMENTS, NEEDS

    assert set(NEEDS) == set(EXPERIMENTS)
    assert {p for ps in NEEDS.values() for p in ps} <= set(cli.EXTRA_OF)
