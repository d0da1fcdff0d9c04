"""Every command shown in README.md runs as written (at a tiny size).

How: the commands are extracted from the README itself -- every line of its ```bash blocks
(continuation lines joined), every inline code span that starts with ``python `` or
``bash `` or ``for ``, and every ```python block -- and run one by one, in README order, in a
scratch folder holding a copy of ``scenes/``, ``benchmarks/`` and ``examples/`` (so nothing is written into
the repository), with this checkout on PYTHONPATH.

What is changed on the way is listed here, explicitly, so that a reader can check that the
mapping is honest:

* ``python`` and ``python3`` are a shim (:data:`SHIM`) that appends :data:`TINY` options
  (smaller images, grids and repeats) to the commands it recognises, then runs this
  interpreter. Nothing else about the command changes.
* :data:`SETUP_REWRITES`: the quick start's venv and pip steps are dropped (CI's ``.ci/run``
  has just done exactly them) and ``.venv/bin/python`` is the shim.
* :data:`PLACEHOLDERS`: names the README uses for "your file" (``SCENE.json``, ``DIR``, ...)
  become concrete files. A synopsis (a command with ``[optional]`` parts) is run without its
  optional parts, and every option it lists must appear in the command's ``--help``.
* :data:`NOT_RUN`: commands that are not run, each with the reason. :data:`MENTIONS`:
  inline spans that name a command without being one.
* :data:`PYTHON_REWRITES`: image sizes in the Python examples. A ```python block with a
  ``...`` placeholder is a fragment and is only compiled.

:data:`PENDING` lists the commands expected to fail until another change lands (issue 13
gives the study commands defaults for ``-o``); they are ``xfail(strict=True)``, so the
marker must be removed once they pass.
"""

import os
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"

pytestmark = pytest.mark.slow

#: options appended by the shim, per ``python -m tracer <command>`` or script
TINY = {
    "tracer render": ["--size", "16", "16"],
    "tracer compare": ["--grid", "8", "--size", "16", "16"],
    # the studies (issue 13 owns them; adjust these when their options change)
    "tracer ablate-beta": ["--size", "8", "--betas", "0,1", "--grid-betas", "0,1",
                           "--types", "points"],
    "tracer ablate-alpha": ["--size", "8"],
    "tracer bench-grid": ["--grid", "4"],
    "tracer bh-switch": ["--trials", "4", "--samples", "11"],
    "benchmarks/bench_render.py": ["--sizes", "8", "--repeat", "1", "--types", "points"],
    "benchmarks/bench_grid.py": ["--grid", "4", "--repeat", "1"],
    "benchmarks/bench_mesh_distance.py": ["--repeat", "1", "--case", "ring-toss"],
    "examples/mesh_distance_demo.py": ["--size", "16", "--out", "out/demo"],
    "benchmarks/bench_authors.py": ["--sizes", "8", "--repeat", "1", "--types", "points"],
    "benchmarks/bench_tol.py": ["--size", "8", "--types", "points", "--tol", "0.01",
                                "--stride", "4", "--repeat", "1"],
    "benchmarks/bench_scale.py": ["--points", "20000", "--size", "8"],
    "benchmarks/bench_sim.py": ["--steps", "3"],
    "tracer simulate": ["--size", "16", "12", "--steps", "3"],
    "tracer animate": ["--size", "16", "12"],
    "benchmarks/bench_studies.py": ["--size", "8", "--betas", "1", "--grid", "4",
                                    "--trivial", "4", "--folder", "scenes/data/meshes"],
}

SHIM = textwrap.dedent('''\
    #!{python}
    # README-command shim: append tiny-size options, then run the real interpreter
    import os, sys
    TINY = {tiny!r}
    args = sys.argv[1:]
    key = " ".join(args[1:3]) if args[:1] == ["-m"] else (args[0] if args else "")
    extra = TINY.get(key, [])
    if "--help" in args or "-h" in args:
        extra = []
    os.execv({python!r}, [{python!r}] + args + extra)
''')

SETUP_REWRITES = [
    ('python3 -m venv .venv && ', ''),
    ('.venv/bin/pip install -q -e ".[test]" && ', ''),
    ('.venv/bin/python ', 'python '),
]

PLACEHOLDERS = {
    "SCENE.json": "scenes/trefoil.json",
    "scene.json": "scenes/trefoil.json",
    "PATH": "scenes/data/curves/trefoil.obj",
    "DIR": "out/dir",
    "MESH_DIR": "scenes/data/meshes",
    "SIM.json": "scenes/simulations/ball_on_plane.json",
    "DIR/trajectory.npz": "out/dir/trajectory.npz",
    "OUT_DIR": "out/grid",
    "A.png": "a.png",
    "B.png": "b.png",
}

NOT_RUN = {
    "python benchmarks/bench_authors.py --authors-bin PATH":
        "it needs the authors' renderer built outside the repository "
        "(../shared/tools/authors-bench); the same script without --authors-bin is run",
    "python benchmarks/bench_authors.py --authors-bin PATH --sizes 256 512 --repeat 2 --our-eps":
        "it needs the authors' renderer built outside the repository "
        "(../shared/tools/authors-bench); the same script without --authors-bin is run",
    "python -m tracer bench-grid MESH_DIR -o OUT_DIR --scheduler tcp://host:8786 # an existing cluster":
        "it needs an existing Dask cluster; tests/test_runner_cluster.py starts one with the "
        "dask command line and runs this command against it",
    "bash .ci/run": "it runs this test suite (CI runs it)",
    'bash .ci/run -m "not slow"': "it runs the quick part of this test suite",
    "python -m tests.test_render_golden --regen [CASE ...]":
        "it rewrites the repository's baselines; tests/test_render_golden.py tests --regen",
}

MENTIONS = {"python -m tracer", "python -m tracer render"}

PYTHON_REWRITES = [
    (r"size=\(512, 512\)", "size=(16, 16)"),
    (r"width=256, height=256", "width=16, height=16"),
]

#: commands that fail until issue 13 lands (the studies' -o defaults); remove after merging
PENDING = set()


# ----------------------------------------------------------------------------- extraction
def readme_commands(text=None):
    """``[(kind, command)]`` in README order; kind is ``"bash"`` or ``"python"``."""
    text = README.read_text(encoding="utf-8") if text is None else text
    out = []
    fence = re.compile(r"^```(\w*)\s*$")
    lang, block = None, []
    for line in text.splitlines():
        m = fence.match(line)
        if m and lang is None:
            lang, block = m.group(1) or "text", []
            continue
        if m and lang is not None:
            if lang == "bash":
                joined = "\n".join(block).replace("\\\n", " ")
                for cmd in joined.splitlines():
                    cmd = re.sub(r"\s+", " ", cmd).strip()
                    if cmd and not cmd.startswith("#"):
                        out.append(("bash", cmd))
            elif lang == "python":
                out.append(("python", "\n".join(block)))
            lang = None
            continue
        if lang is not None:
            block.append(line)
            continue
        for span in re.findall(r"`([^`]+)`", line):
            if re.match(r"(python|bash|for) ", span) or span in MENTIONS:
                out.append(("bash", span.strip()))
    return out


def _id(item):
    kind, cmd = item
    first = cmd.strip().splitlines()[0] if cmd.strip() else ""
    return (kind + ": " + first)[:80]


COMMANDS = [c for c in readme_commands() if c[1] not in MENTIONS]


def concrete(cmd):
    """The command as run here: setup rewrites, placeholders, optional parts dropped."""
    for old, new in SETUP_REWRITES:
        cmd = cmd.replace(old, new)
    cmd = re.sub(r"\s*\[[^\[\]]*\]", "", cmd)  # [optional] parts of a synopsis
    cmd = re.sub(r"\s+#\s.*$", "", cmd)  # a trailing shell comment
    tokens = cmd.split(" ")
    for i, tok in enumerate(tokens):
        if tok in PLACEHOLDERS:
            tokens[i] = PLACEHOLDERS[tok]
        elif re.fullmatch(r"[A-Z][A-Z_]+(\.[a-z]+)?", tok):
            raise AssertionError(f"README command {cmd!r} has a placeholder {tok!r}: add it to "
                                 "PLACEHOLDERS in tests/test_readme.py")
    return " ".join(tokens)


def synopsis_options(cmd):
    """Options (``--x``, ``-o``) named in a synopsis's ``[...]`` parts."""
    return sorted(set(re.findall(r"\[(-{1,2}[\w-]+)", cmd)))


# ----------------------------------------------------------------------------- running
@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    """A scratch folder with scenes/ and benchmarks/, a shim ``python`` on PATH, and a record
    of the commands run so far (some README commands use the output of an earlier one)."""
    base = tmp_path_factory.mktemp("readme")
    work = base / "work"
    work.mkdir()
    shutil.copytree(ROOT / "scenes", work / "scenes")
    shutil.copytree(ROOT / "benchmarks", work / "benchmarks")
    shutil.copytree(ROOT / "examples", work / "examples")
    bindir = base / "bin"
    bindir.mkdir()
    for name in ("python", "python3"):
        p = bindir / name
        p.write_text(SHIM.format(python=sys.executable, tiny=TINY))
        p.chmod(0o755)
    env = dict(os.environ)
    env["PATH"] = f"{bindir}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"]
                                     if env.get("PYTHONPATH") else "")
    env["MPLBACKEND"] = "Agg"
    env.pop("TRACER_REGEN_BASELINES", None)
    # two small images for the diff synopsis (A.png, B.png)
    import numpy as np

    from tracer.image import save_png

    img = np.full((8, 8, 3), 200, np.uint8)
    save_png(work / "a.png", img)
    save_png(work / "b.png", img)
    return {"work": work, "env": env, "done": {}}


def run_bash(ws, cmd, timeout=600):
    return subprocess.run(["bash", "-e", "-o", "pipefail", "-c", cmd], cwd=ws["work"],
                          env=ws["env"], capture_output=True, text=True, timeout=timeout)


def run_readme_command(ws, cmd):
    """Run one README bash command (and, first, the earlier commands whose outputs it uses)."""
    if cmd in ws["done"]:
        return ws["done"][cmd]
    for kind, earlier in COMMANDS:
        if earlier == cmd:
            break
        outs = re.findall(r"--save-scene (\S+)", earlier)
        if kind == "bash" and any(o in cmd for o in outs):
            run_readme_command(ws, earlier)
    proc = run_bash(ws, concrete(cmd))
    ws["done"][cmd] = proc
    return proc


def test_readme_has_commands():
    cmds = [c for k, c in COMMANDS if k == "bash"]
    assert any(c.startswith("python -m tracer render scenes/data/") for c in cmds)
    assert any("--save-scene" in c for c in cmds)
    assert sum(k == "python" for k, _ in COMMANDS) >= 2
    for cmd in NOT_RUN:
        assert cmd in cmds, f"NOT_RUN lists {cmd!r}, which the README no longer shows"
    for cmd in PENDING:
        assert cmd in cmds, f"PENDING lists {cmd!r}, which the README no longer shows"


@pytest.mark.parametrize("item", [pytest.param(
    c, id=_id(c), marks=[pytest.mark.xfail(strict=True, reason="the studies get -o defaults "
                                           "in issue 13; remove from PENDING after merging")]
    if c[1] in PENDING else []) for c in COMMANDS])
def test_readme_command_runs(workspace, item):
    kind, cmd = item
    if kind == "python":
        code = cmd
        if re.search(r"(^|[^.])\.\.\.([^.]|$)", code):
            compile(code, "README.md", "exec")  # a fragment with placeholders
            return
        for pat, rep in PYTHON_REWRITES:
            code = re.sub(pat, rep, code)
        script = workspace["work"] / "snippet.py"
        script.write_text(code)
        proc = run_bash(workspace, f"python {script.name}")
        assert proc.returncode == 0, proc.stderr[-2000:]
        return
    if cmd in NOT_RUN:
        pytest.skip(NOT_RUN[cmd])
    if "[" in cmd:  # a synopsis: every option it lists exists
        base = concrete(cmd).split(" ")
        sub = base[:4] if base[1:3] == ["-m", "tracer"] else base[:2]
        helptext = run_bash(workspace, " ".join(sub) + " --help").stdout
        for opt in synopsis_options(cmd):
            assert re.search(rf"(^|[\s,\[]){re.escape(opt)}([\s,=\]]|$)", helptext, re.M), \
                (cmd, opt)
    proc = run_readme_command(workspace, cmd)
    assert proc.returncode == 0, (concrete(cmd), proc.stderr[-2000:])
