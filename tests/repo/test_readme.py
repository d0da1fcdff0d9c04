"""Every command shown in README.md and in the user guide (``docs/getting-started.md``,
``docs/guide/*.md``) runs as written (at a tiny size).

How: the commands are extracted from the pages themselves (:data:`PAGES`) -- every line of their
```bash blocks (continuation lines joined), every inline code span that starts with ``python ``
or ``bash `` or ``for `` (a span may run over a line break within its paragraph), and every
```python block -- and run one by one, page by page (README first) in page order, in a scratch
folder holding a copy of ``scenes/``, ``benchmarks/`` and ``examples/`` (so nothing is written
into the repository), with this checkout on PYTHONPATH. Each test is named after its page and
command. MyST directives (```{toctree}, ```{image}, ... blocks) are not commands and are
skipped whole; ``:::`` fence lines are skipped and the Markdown between them is read as usual;
other fenced blocks (```json, ```ini, ...) are not commands either. A command shown on several
pages runs once: the later occurrences reuse its result (the key is the command as run, see
:func:`concrete`, or the code of a python block).

What is changed on the way is listed here, explicitly, so that a reader can check that the
mapping is honest:

* ``python`` and ``python3`` are a shim (:data:`SHIM`) that appends :data:`TINY` options
  (smaller images, grids and repeats) to the commands it recognises, then runs the command
  with this interpreter: in a fork of one prepared for it (``command_server.py``, which has
  imported numpy, numba, scipy, matplotlib, PIL and trimesh, but not our packages, and set
  up numba's tables: about 0.7 s of CPU that each of the hundred commands would otherwise
  spend before its work; its docstring lists what a command sees), or afresh where the
  server declines (interpreter options, an environment that sets what those modules read).
  :func:`test_commands_run_as_in_a_fresh_interpreter` compares the two. Nothing else about
  the command changes.
* :data:`SETUP_REWRITES`: the quick start's venv and pip steps are dropped (CI's ``.ci/run``
  has just made the venv and installed the ``test`` extra, which holds the quick start's
  ``tracer`` extra) and ``.venv/bin/python`` is the shim.
* :data:`PLACEHOLDERS`: names the pages use for "your file" (``SCENE.json``, ``DIR``, ...)
  become concrete files. A synopsis (a command with ``[optional]`` parts) is run without its
  optional parts, and every option it lists must appear in the command's ``--help``.
* :data:`NOT_RUN`: commands that are not run, each with the reason. :data:`MENTIONS`:
  inline spans that name a command without being one.
* :data:`FRESH`: commands that are alternatives to an earlier one and, at the tiny size, would
  find its results and refuse to replace them; they run unchanged in a fresh scratch folder.
* :data:`PYTHON_REWRITES`: image sizes in the Python examples. A ```python block with a
  ``...`` placeholder in its code (not in a comment: :func:`is_fragment`) is a fragment and is
  only compiled. A block whose first line is a comment naming a file ``# test_*.py`` (a user's
  test) is also written to that file in the scratch folder, where the page's
  ``python -m pytest`` commands run it.

:data:`PENDING` lists the commands expected to fail until another change lands (issue 13
gives the study commands defaults for ``-o``); they are ``xfail(strict=True)``, so the
marker must be removed once they pass.
"""

import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
#: the fork server the ``python`` shim hands commands to (its docstring: what it changes)
SERVER = Path(__file__).resolve().parent / "command_server.py"
GUIDE = ROOT / "docs" / "guide"
#: the pages whose commands run, in this order (README first; the guide pages by name)
PAGES = [README, ROOT / "docs" / "getting-started.md"] + sorted(GUIDE.glob("*.md"))

pytestmark = pytest.mark.slow

#: options appended by the shim, per ``python -m tracer <command>`` or script
TINY = {
    "tracer render": ["--size", "16", "16"],
    # two quick jobs of the warm-up (every job: minutes of compiling on a cold CI cache)
    "tracer warmup": ["--only", "render-points", "smooth-distance"],
    "smoothdist warmup": ["--only", "smooth-distance"],
    # 1080p renders of 50k and 1M points, three ways each: two minutes of the suite (issue 63)
    "benchmarks/bench_cloud_1080.py": ["--points", "2000", "--size", "64", "36"],
    "tracer compare": ["--grid", "8", "--size", "16", "16"],
    # the studies (issue 13 owns them; adjust these when their options change)
    "tracer ablate-beta": ["--size", "8", "--betas", "0,1", "--grid-betas", "0,1",
                           "--types", "points"],
    "tracer ablate-alpha": ["--size", "8"],
    "tracer bench-grid": ["--grid", "4"],
    "tracer bh-switch": ["--trials", "4", "--samples", "11"],
    "benchmarks/bench_render.py": ["--sizes", "8", "--repeat", "1", "--types", "points"],
    "benchmarks/bench_grid.py": ["--grid", "4", "--repeat", "1"],
    "benchmarks/bench_fidelity.py": ["--size", "16", "--shapes", "icosphere1", "helix_polyline"],
    "benchmarks/bench_exact_mix.py": ["--sizes", "10k", "--mixes", "near", "--kinds-on", "none",
                                      "--grid", "6", "--queries", "5000", "--repeat", "1",
                                      "--smooth-queries", "300", "--shapes", "needle"],
    "benchmarks/bench_ripple.py": ["--cases", "circle64", "--size", "16"],
    "benchmarks/bench_specks.py": ["--no-clouds", "--scenes", "trefoil"],
    "benchmarks/bench_mesh_distance.py": ["--repeat", "1", "--case", "ring-toss"],
    "examples/mesh_distance_demo.py": ["--size", "16", "--out", "out/demo"],
    "benchmarks/bench_authors.py": ["--sizes", "8", "--repeat", "1", "--types", "points"],
    "benchmarks/bench_tol.py": ["--size", "8", "--types", "points", "--tol", "0.01",
                                "--stride", "4", "--repeat", "1"],
    "benchmarks/bench_scale.py": ["--points", "20000", "--size", "8"],
    "benchmarks/bench_build_scale.py": ["--sizes", "1e3", "--kinds", "triangles", "--libraries",
                                        "ours", "--queries", "300", "--no-render"],
    "benchmarks/bench_sim.py": ["--steps", "3"],
    "tracer simulate": ["--size", "16", "12", "--steps", "3"],
    "tracer animate": ["--size", "16", "12"],
    "benchmarks/bench_quality.py": ["--cost-size", "16", "--quality-size", "8", "--reference",
                                    "8", "--samples", "4", "--repeat", "1"],
    # one cluster size of the two (each of its six cluster starts costs a second or two)
    "benchmarks/bench_studies.py": ["--size", "8", "--betas", "1", "--grid", "4",
                                    "--trivial", "4", "--folder", "scenes/data/meshes",
                                    "--modes", "serial,local-2"],
    "benchmarks/bench_frame.py": ["--size", "16", "9", "--repeat", "1"],
    # every shape lit at 128²: 22 s of the suite; two shapes at 16² run the same code
    "benchmarks/bench_self_shadow.py": ["--size", "16", "--shapes", "icosphere1", "open_plane"],
    "tracer.sim.vbowl -o": ["--steps", "20"],
    "benchmarks/bench_scaling.py": ["--size", "16", "9", "--repeat", "1", "--threads", "1", "2"],
    "benchmarks/bench_png.py": ["--size", "16", "9", "--repeat", "1", "--threads", "1", "2",
                                "--kinds", "points"],
    "benchmarks/bench_gpu_cone_end.py": ["--size", "16", "9", "--kinds", "points"],
    "benchmarks/bench_film_host.py": ["--size", "16", "9", "--samples", "4"],
}

SHIM = textwrap.dedent('''\
    #!{python}
    # README-command shim: append tiny-size options, then run the command in a fork of the
    # prepared interpreter (command_server.py), or in a fresh one where the server declines
    import array, json, os, socket, struct, sys
    TINY = {tiny!r}
    args = sys.argv[1:]
    key = " ".join(args[1:3]) if args[:1] == ["-m"] else (args[0] if args else "")
    extra = TINY.get(key, [])
    if "--help" in args or "-h" in args:
        extra = []
    args = args + extra
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        s.connect({socket_path!r})
    except OSError:  # no server (a command run by hand from the scratch folder)
        s.close()
        os.execv({python!r}, [{python!r}] + args)
    msg = json.dumps({{"argv": args, "cwd": os.getcwd(), "env": dict(os.environ)}})
    s.sendmsg([msg.encode() + b"\\n"],
              [(socket.SOL_SOCKET, socket.SCM_RIGHTS, array.array("i", [0, 1, 2]))])
    got = b""
    while len(got) < 4:
        more = s.recv(4 - len(got))
        if not more:
            sys.exit("error: the command server's process ended without an exit status")
        got += more
    code = struct.unpack("i", got)[0]
    if code >= 0:  # else the server declined: a fresh interpreter
        sys.exit(code)
    os.execv({python!r}, [{python!r}] + args)
''')

SETUP_REWRITES = [
    ('python3 -m venv .venv && ', ''),
    ('.venv/bin/pip install -q -e ".[tracer]" && ', ''),
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
    "part.stl": "scenes/data/meshes/torus.obj",
}

NOT_RUN = {
    "python benchmarks/bench_coldstart_ab.py --before /tmp/before --cases mesh edges cloud lit "
    "--rounds 2":
        "it needs a checkout of the code before (git worktree) and compiles first renders from "
        "an empty cache sixteen times per round (minutes); tests/repo/test_docs_tables.py "
        "checks the guide against its results file",
    "python benchmarks/bench_coldstart_ab.py --before /tmp/before --cases mesh edges cloud lit "
    "mesh_exact two_objects mesh_normals --modes cold_ahead --rounds 3":
        "it needs a checkout of the code before (git worktree) and compiles first renders from "
        "an empty cache fourteen times per round (minutes); tests/repo/test_docs_tables.py "
        "checks the guide against its results file",
    "python benchmarks/bench_library_ab.py --before /tmp/before --rounds 3":
        "it needs a checkout of the code before (git worktree) and compiles the whole-mesh "
        "vertex gradient's kernels in each (a minute); tests/repo/test_docs_tables.py checks "
        "the guide against its results file",
    "python benchmarks/bench_coldstart_ab.py":
        "it needs a checkout of the code before (git worktree) and compiles a first render's "
        "kernels from an empty cache four times per case and round (minutes); "
        "tests/repo/test_docs_tables.py checks the guide against its results file",
    "python benchmarks/timeline_first_render.py":
        "it compiles a first render's kernels from an empty cache (20 s of the suite); "
        "tests/tracer/scenes/test_compile_ahead.py runs a first render with its child and "
        "tests/repo/test_docs_tables.py checks the guide against its results file",
    "python benchmarks/profile_compile.py":
        "it compiles every kernel three times over with empty caches (a minute); "
        "tests/repo/test_docs_tables.py checks the guide against its results file and "
        "tests/tracer/rendering/test_render_coldstart.py the compiled kernels of a first render",
    "python benchmarks/bench_coldstart.py":
        "it compiles every kernel from an empty cache six times (minutes); "
        "tests/tracer/rendering/test_render_coldstart.py runs a first lit render with an empty "
        "cache",
    "python benchmarks/bench_coldstart.py --copies --out benchmarks/data/coldstart_issue63.json":
        "it compiles every kernel from an empty cache more than six times over, and the warm-up "
        "once (minutes); tests/smoothdist/test_kernel_cache.py shows a second copy loading the "
        "kernels and tests/smoothdist/test_warmup.py a first call after the warm-up compiling "
        "nothing",
    "python benchmarks/bench_coldstart.py --copies --cases mesh_exact mesh_tol --out "
    "benchmarks/data/coldstart_issue63_modes.json":
        "it compiles two first renders from an empty cache four times over, and the warm-up "
        "once (minutes); tests/repo/test_docs_tables.py checks the guide against its results "
        "file and tests/smoothdist/test_warmup.py the warm-up's jobs",
    "python benchmarks/bench_coldstart.py --cases sim --out "
    "benchmarks/data/coldstart_issue63_sim_ahead.json":
        "it compiles a first simulation step from an empty cache twice (a minute); "
        "tests/tracer/sim/test_sim_compile_ahead.py runs one with its child on an empty cache "
        "and tests/repo/test_docs_tables.py checks the guide against its results file",
    "python benchmarks/bench_coldstart.py --cases mesh_normals two_objects --out "
    "benchmarks/data/coldstart_issue63_unlit_ahead.json":
        "it compiles two first renders from an empty cache twice each (a minute); "
        "tests/tracer/scenes/test_compile_ahead.py runs an unlit one with its child on an empty "
        "cache and tests/repo/test_docs_tables.py checks the guide against its results file",
    "python benchmarks/bench_authors_error.py --authors-bin PATH --size 256 --json "
    "tracer/studies/authors_beta_error.json":
        "it needs the authors' renderer built outside the repository (benchmarks/authors) and "
        "takes minutes; tests/tracer/studies/test_studies.py reads the file it wrote",
    "python benchmarks/bench_authors.py --authors-bin PATH":
        "it needs the authors' renderer built outside the repository "
        "(benchmarks/authors); the same script without --authors-bin is run",
    "python benchmarks/bench_authors.py --authors-bin PATH --sizes 256 512 --repeat 2 --our-eps":
        "it needs the authors' renderer built outside the repository "
        "(benchmarks/authors); the same script without --authors-bin is run",
    "python benchmarks/bench_authors.py --authors-bin PATH --sizes 512 --repeat 3 --our-eps":
        "it needs the authors' renderer built outside the repository "
        "(benchmarks/authors); the same script without --authors-bin is run",
    "python -m tracer bench-grid MESH_DIR -o OUT_DIR --scheduler tcp://host:8786 # an existing cluster":
        "it needs an existing Dask cluster; tests/tracer/test_runner_cluster.py starts one with "
        "the dask command line and runs this command against it",
    "python benchmarks/bench_authors_sim.py --authors-bin "
    "../authors-build/bench/rigid_body_simulator scenes/simulations/table3/ico_bowl.json "
    "--steps 400 --timeout 1200":
        "it needs the authors' simulator built outside the repository "
        "(benchmarks/authors) and takes minutes; tests/repo/test_bench_authors_sim.py "
        "runs the script against a stand-in simulator",
    "python benchmarks/bench_mesh_distance.py --authors-bin ../authors-build/bench/mesh_bench "
    "--rounds 5 --repeat 10 --threads 2 --json benchmarks/data/mesh_distance_authors.json":
        "it needs the authors' mesh_bench built outside the repository "
        "(benchmarks/authors); the same script without --authors-bin is run",
    "python benchmarks/tables.py mesh-distance benchmarks/data/mesh_distance_authors.json":
        "it reads the results of the side-by-side run above (the authors' mesh_bench, built "
        "outside the repository), which no run has written yet; tests/repo/test_docs_tables.py "
        "ties the table to the file once it exists",
    "python -m tracer render scenes/bunny_points.json --size 1920 1080 --shading normals "
    "--device cuda":
        "it needs an NVIDIA GPU; tests/smoothdist/test_cuda_sim.py runs the same path under "
        "numba's CUDA simulator, and the error without a GPU",
    'pip install -e ".[gpu]" # in the clone: numba-cuda; a CUDA driver on the machine':
        "it installs the optional GPU extra into the environment that runs the tests (whose "
        "test extra already holds numba-cuda); tests/smoothdist/test_cuda_sim.py runs the CUDA "
        "path",
    "bash benchmarks/run_on_card.sh OUT machine gpu scaling":
        "it needs an NVIDIA GPU (nvidia-smi, numba-cuda on a card) and takes minutes; "
        "tests/smoothdist/test_cuda_sim.py runs bench_gpu's measurement functions under the "
        "simulator, and its refusal without a GPU",
    "bash benchmarks/run_on_card.sh OUT regs":
        "it needs an NVIDIA GPU (nvidia-smi, numba-cuda on a card) and takes minutes; "
        "tests/smoothdist/test_cuda_sim.py runs bench_gpu's register-capped variants (grid and "
        "render) under the simulator",
    "python benchmarks/check_cuda_ptx.py --ptxas --max-registers 128 96 64":
        "it needs NVIDIA's NVVM and ptxas (pip wheels CI does not install) and assembles every "
        "kernel four times (minutes); tests/smoothdist/test_cuda_registers.py tests its "
        "occupancy arithmetic, its reading of ptxas and the committed report",
    "bash benchmarks/run_on_card.sh OUT card":
        "it needs an NVIDIA GPU (nvidia-smi, numba-cuda on a card) and takes about 8 minutes; "
        "tests/smoothdist/test_cuda_sim.py runs bench_gpu's measurement functions (the kernel "
        "variants and the lit look's parts too) under the simulator",
    "python -m tracer reproduce --only beta":
        "it is the full reproduction's beta study at the paper's 512² (minutes); "
        "tests/tracer/reproduce/test_reproduce.py::test_quick_run_end_to_end runs the same "
        "experiment at --quick's size, and python -m tracer ablate-beta, which it runs, is run "
        "from this page",
    "python -m tracer reproduce --report-only --docs":
        "it rewrites the result blocks of the repository's own guides; "
        "tests/tracer/reproduce/test_reproduce.py checks the guides against the committed results "
        "with the same code",
    "for s in scenes/*.json; do python -m tracer render $s -o renders/gallery/$(basename "
    "${s%.json}).png --size 512 512 --shading lit --samples 16 --adaptive --overwrite; done":
        "it starts one interpreter per scene (14); tests/tracer/rendering/test_render_golden.py runs the same "
        "command line for every scene in-process (test_every_scene_renders_lit_from_the_"
        "command_line)",
    "python benchmarks/bench_studies.py --grid 50":
        "with the test's tiny options appended (--grid 4) it is the command above, which runs",
    "python scenes/simulations/table3/make_meshes.py --check "
    "# the committed meshes, regenerated and compared":
        "tests/tracer/sim/test_sim_table3.py::test_make_meshes_is_reproducible runs this very "
        "command",
    "bash .ci/run": "it runs this test suite (CI runs it)",
    'bash .ci/run -m "not slow"': "it runs the quick part of this test suite",
    "python -m pytest tests/tracer/rendering/test_render_golden.py --regen-baselines":
        "it rewrites the repository's baselines; tests/tracer/test_pytest_plugin.py tests "
        "--regen-baselines in a throwaway project",
    ".venv/bin/python -m sphinx -W --keep-going docs docs/_build/html":
        "it builds the whole documentation site, gallery and notebook included (minutes); "
        "tests/repo/test_docs.py builds it in the suite",
}

MENTIONS = {"python -m tracer", "python -m tracer render"}

FRESH = {
    "python -m tracer ablate-beta scenes/data/bunny.off --size 512":
        "the 512² study; at the tiny size it writes the folder of the 256² run before it",
    "python -m tracer ablate-alpha metric":
        "one of the alpha studies instead of 'all', whose results it would find",
    "python -m tracer ablate-beta scenes/data/bunny.off --tols "
    "3e-4,1e-3,3e-3,3.5e-3,1e-2,3e-2,0.1,0.3,1,3,10 --scheduler serial":
        "the study with the tol series; at the tiny size it writes the folder of the plain "
        "study before it",
}

PYTHON_REWRITES = [
    (r"size=\(512, 512\)", "size=(16, 16)"),
    (r"size=\(128, 128\)", "size=(16, 16)"),
    (r"width=256, height=256", "width=16, height=16"),
]

#: commands that fail until issue 13 lands (the studies' -o defaults); remove after merging
PENDING = set()


# ----------------------------------------------------------------------------- extraction
FENCE = re.compile(r"^\s*(`{3,}|~{3,})\s*([^`\s]*)")
COLON_FENCE = re.compile(r"^\s*:{3,}")


def page_commands(text):
    """``[(kind, command)]`` in page order; kind is ``"bash"`` or ``"python"``.

    Fenced ```bash blocks give one command per line (continuations joined, comment lines
    dropped); ```python blocks one command each; MyST directive blocks (```{name}) and other
    languages none. Inline spans are read per paragraph, so a span may wrap a line."""
    out = []
    fence, lang, block, para = None, None, [], []

    def spans():
        joined = " ".join(para)
        for span in re.findall(r"`([^`]+)`", joined):
            span = re.sub(r"\s+", " ", span).strip()
            if re.match(r"(python|bash|for) ", span) or span in MENTIONS:
                out.append(("bash", span))
        para.clear()

    for line in text.splitlines():
        if fence is not None:  # inside a fenced block
            m = FENCE.match(line)
            if m and m.group(1)[0] == fence[0] and len(m.group(1)) >= len(fence) \
                    and not m.group(2):
                if lang == "bash":
                    joined = "\n".join(block).replace("\\\n", " ")
                    for cmd in joined.splitlines():
                        cmd = re.sub(r"\s+", " ", cmd).strip()
                        if cmd and not cmd.startswith("#"):
                            out.append(("bash", cmd))
                elif lang == "python":
                    out.append(("python", "\n".join(block)))
                fence = None
            else:
                block.append(line)
            continue
        m = FENCE.match(line)
        if m:
            spans()
            fence, lang, block = m.group(1), m.group(2) or "text", []
            continue
        if COLON_FENCE.match(line) or not line.strip() or line.lstrip().startswith("#"):
            spans()  # a MyST ::: fence line, a blank line or a heading ends a paragraph
            if line.lstrip().startswith("#"):
                para.append(line)
                spans()
            continue
        para.append(line)
    spans()
    return out


def readme_commands(text=None):
    """The README's commands (as :func:`page_commands`)."""
    return page_commands(README.read_text(encoding="utf-8") if text is None else text)


def _page(path):
    return path.relative_to(ROOT).as_posix()


#: ``[(page, kind, command)]`` of every page, in run order
COMMANDS = [(_page(p), kind, cmd) for p in PAGES
            for kind, cmd in page_commands(p.read_text(encoding="utf-8"))
            if cmd not in MENTIONS]


def _id(item):
    page, kind, cmd = item
    first = cmd.strip().splitlines()[0] if cmd.strip() else ""
    return f"{page}: {kind}: {first}"[:100]


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
            raise AssertionError(f"command {cmd!r} has a placeholder {tok!r}: add it to "
                                 "PLACEHOLDERS in tests/repo/test_readme.py")
    return " ".join(tokens)


def synopsis_options(cmd):
    """Options (``--x``, ``-o``) named in a synopsis's ``[...]`` parts."""
    return sorted(set(re.findall(r"\[(-{1,2}[\w-]+)", cmd)))


def is_fragment(code):
    """A python block with ``...`` as code (a placeholder, not in a comment or a string)."""
    import io
    import tokenize

    toks = tokenize.generate_tokens(io.StringIO(code).readline)
    return any(t.type == tokenize.OP and t.string == "..." for t in toks)


def python_code(code):
    """A python block as run here (:data:`PYTHON_REWRITES`)."""
    for pat, rep in PYTHON_REWRITES:
        code = re.sub(pat, rep, code)
    return code


# ----------------------------------------------------------------------------- running
def make_work(work):
    """A scratch folder: copies of scenes/, benchmarks/, examples/, an empty renders/ and two
    small images for the diff synopsis (A.png, B.png)."""
    import numpy as np

    from tracer.image import save_png

    work.mkdir()
    for name in ("scenes", "benchmarks", "examples"):
        shutil.copytree(ROOT / name, work / name)
    # a clone has renders/ (the gallery): snippets that save there must not depend on an
    # earlier command of the same test worker having made it
    (work / "renders").mkdir()
    img = np.full((8, 8, 3), 200, np.uint8)
    save_png(work / "a.png", img)
    save_png(work / "b.png", img)
    return work


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    """A scratch folder, a shim ``python`` on PATH, and a record of the commands run so far
    (some commands use the output of an earlier one; a command shown twice runs once)."""
    base = tmp_path_factory.mktemp("readme")
    sock = base / "server.sock"
    work = make_work(base / "work")
    bindir = base / "bin"
    bindir.mkdir()
    for name in ("python", "python3"):
        p = bindir / name
        p.write_text(SHIM.format(python=sys.executable, tiny=TINY, socket_path=str(sock)))
        p.chmod(0o755)
    env = dict(os.environ)
    env["PATH"] = f"{bindir}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"]
                                     if env.get("PYTHONPATH") else "")
    env["MPLBACKEND"] = "Agg"
    server = subprocess.Popen([sys.executable, str(SERVER), str(sock)], env=env,
                              stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        while not sock.exists() and server.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert sock.exists(), "the command server did not start"
        yield {"base": base, "work": work, "env": env, "done": {}}
    finally:
        server.kill()
        server.wait()


def run_bash(ws, cmd, timeout=600, cwd=None):
    return subprocess.run(["bash", "-e", "-o", "pipefail", "-c", cmd], cwd=cwd or ws["work"],
                          env=ws["env"], capture_output=True, text=True, timeout=timeout)


def run_page_command(ws, cmd):
    """Run one bash command (and, first, the earlier commands whose outputs it uses)."""
    key = concrete(cmd)
    if key in ws["done"]:
        return ws["done"][key]
    for _, kind, earlier in COMMANDS:
        if earlier == cmd:
            break
        outs = re.findall(r"--save-scene (\S+)", earlier)
        if kind == "bash" and any(o in cmd for o in outs):
            run_page_command(ws, earlier)
    cwd = None
    if cmd in FRESH:
        cwd = make_work(ws["base"] / f"fresh{len(ws['done'])}")
    proc = run_bash(ws, key, cwd=cwd)
    ws["done"][key] = proc
    return proc


def run_python_block(ws, code):
    """Run one python block as a script in the scratch folder (once per distinct block)."""
    code = python_code(code)
    if code in ws["done"]:
        return ws["done"][code]
    m = re.match(r"#\s*(test_\w+\.py)\b", code.lstrip())
    if m:  # a user's test file: the page's pytest commands run it
        (ws["work"] / m.group(1)).write_text(code)
    script = ws["work"] / "snippet.py"
    script.write_text(code)
    proc = run_bash(ws, f"python {script.name}")
    ws["done"][code] = proc
    return proc


def test_pages_have_commands():
    assert README in PAGES and len(PAGES) >= 3
    for page in PAGES:
        assert page.is_file(), page
    cmds = [c for _, k, c in COMMANDS if k == "bash"]
    readme = [c for p, _, c in COMMANDS if p == "README.md"]
    assert any(c.startswith("python -m tracer render scenes/data/") for c in readme)
    assert any("--save-scene" in c for c in cmds)
    assert sum(k == "python" for _, k, _ in COMMANDS) >= 2
    for table in (NOT_RUN, FRESH, PENDING):
        for cmd in table:
            assert cmd in cmds, (f"{cmd!r} is listed in tests/repo/test_readme.py, but no page "
                                 "shows it")


def test_fragments_are_code_with_placeholders():
    assert is_fragment("V, F = ..., ...\nd = f(V, F)")
    assert is_fragment("d = f(alpha=...)")
    assert not is_fragment("res.rgb  # (H, W, ...) arrays\nprint('...')")


def test_myst_directives_are_not_commands():
    text = textwrap.dedent("""\
        ```{toctree}
        :maxdepth: 2

        python -m not_a_command
        ```

        :::{note}
        Run `python -m tracer diff A.png B.png` to compare.
        :::

        A span over a line break: `python -m tracer
        ablate-alpha metric`.

        ```json
        {"python -m x": 1}
        ```
        """)
    assert page_commands(text) == [("bash", "python -m tracer diff A.png B.png"),
                                   ("bash", "python -m tracer ablate-alpha metric")]


PROBE = """\
import json, os, subprocess, sys
parent = subprocess.run(["ps", "-o", "args=", "-p", str(os.getppid())], capture_output=True,
                        text=True).stdout
print(json.dumps({"argv": sys.argv, "path0": sys.path[0], "cwd": os.getcwd(), "name": __name__,
                  "x": os.environ.get("PROBE_X"), "forked": "command_server" + ".py" in parent,
                  "ours": [m for m in ("smoothdist", "tracer") if m in sys.modules],
                  "stdin": sys.stdin.read(),
                  "main": sys.modules["__main__"].__dict__ is globals()}))
sys.exit(int(os.environ.get("PROBE_EXIT", "0")))
"""


def test_commands_run_as_in_a_fresh_interpreter(workspace):
    """The shim's fork server (command_server.py) against the real interpreter: the same
    argv, sys.path[0], working folder, ``__name__``, environment, stdin, exit status and
    stderr, for a script, a module and ``-c``; our packages imported by neither; a command
    whose environment sets a variable the preloaded modules read runs in a fresh one."""
    probe = workspace["base"] / "probe"
    probe.mkdir()
    (probe / "probe.py").write_text(PROBE)
    (probe / "probemod.py").write_text(PROBE)
    real = sys.executable
    for args in ('probe.py a "b c"', "-m probemod a", f"-c {shlex.quote(PROBE)} a"):
        via, fresh = (run_bash(workspace, f"echo in | PROBE_X=1 PROBE_EXIT=3 {py} {args}",
                               cwd=probe) for py in ("python", real))
        assert via.returncode == fresh.returncode == 3, (via.stderr, fresh.stderr)
        a, b = json.loads(via.stdout), json.loads(fresh.stdout)
        assert a.pop("forked") and not b.pop("forked"), args  # the server ran it, forked
        assert a == b and a["x"] == "1" and a["stdin"] == "in\n" and a["ours"] == [], (a, b)
        assert a["main"], args  # __main__ is the command's own module
    declined = run_bash(workspace, "NUMBA_NUM_THREADS=1 python probe.py", cwd=probe)
    assert declined.returncode == 0 and not json.loads(declined.stdout)["forked"]
    for code, status, err in (("raise ValueError('boom')", 1, "ValueError: boom"),
                              ("import sys; sys.exit('bye')", 1, "bye"),
                              ("import sys; sys.exit(None)", 0, "")):
        via = run_bash(workspace, f"python -c {shlex.quote(code)}", cwd=probe)
        assert via.returncode == status and err in via.stderr, (code, via.stderr)


@pytest.mark.parametrize("item", [pytest.param(
    c, id=_id(c), marks=[pytest.mark.xfail(strict=True, reason="the studies get -o defaults "
                                           "in issue 13; remove from PENDING after merging")]
    if c[2] in PENDING else []) for c in COMMANDS])
def test_page_command_runs(workspace, item):
    page, kind, cmd = item
    if kind == "python":
        if is_fragment(cmd):
            compile(cmd, page, "exec")  # a fragment with placeholders
            return
        proc = run_python_block(workspace, cmd)
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
    proc = run_page_command(workspace, cmd)
    assert proc.returncode == 0, (page, concrete(cmd), proc.stderr[-2000:])
