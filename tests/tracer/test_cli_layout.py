"""The command line's layout: one pattern for every sub-command, and packages that depend
downwards only.

* every module of ``tracer.cli.COMMANDS`` exposes ``HELP``, ``add_arguments``, ``needs`` (the
  optional packages it imports, checked before ``run``) and ``run``, and its ``HELP`` is read
  from the source (``tracer --help`` imports no command module);
* the simulator (``tracer/sim``) and the shared modules (``tracer.runner``, ``tracer.outputs``,
  ``tracer.validate``) import nothing of ``tracer.studies``.
"""

import ast
import importlib
import subprocess
import sys
from pathlib import Path

import pytest

from tracer import cli

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("name", sorted(cli.COMMANDS))
def test_every_command_module_has_help_add_arguments_and_run(name):
    spec = cli._available()[name]
    module = importlib.import_module(spec.name)
    assert isinstance(module.HELP, str) and module.HELP and "\n" not in module.HELP
    assert callable(module.add_arguments) and callable(module.run) and callable(module.needs)
    assert cli._help(spec) == module.HELP


def test_the_command_list_imports_no_command_module():
    code = ("import sys, tracer.cli as c\n"
            "c.build_parser(only='')\n"
            "print(' '.join(m for m in c.COMMANDS.values() if m in sys.modules))\n")
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == ""


def _imports(path):
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
            names.update(f"{node.module}.{a.name}" for a in node.names)
    return names


@pytest.mark.parametrize("path", sorted(str(p.relative_to(ROOT)) for p in
                                        [*(ROOT / "tracer" / "sim").glob("*.py"),
                                         ROOT / "tracer" / "runner.py",
                                         ROOT / "tracer" / "outputs.py",
                                         ROOT / "tracer" / "validate.py"]))
def test_no_upward_import_of_the_studies(path):
    bad = sorted(n for n in _imports(ROOT / path) if n.startswith("tracer.studies"))
    assert not bad, bad


def test_only_a_process_of_its_own_freezes_the_garbage_collector_at_its_end():
    # the command as the process (argv None: ``tracer``, ``python -m tracer``) leaves the
    # objects numba made to the process's end instead of a last collection (0.4-0.5 s after a
    # first render); a call from a program (a test, a notebook: argv given) must not freeze
    # that program's collector
    code = ("import atexit, gc, sys\n"
            "atexit.register(lambda: print('frozen', gc.get_freeze_count() > 0))\n"
            "import tracer.cli\n"
            "sys.argv = ['tracer'] + sys.argv[1:]\n"
            "rc = tracer.cli.main(None if sys.argv[1] == 'own' else ['--help'])\n")
    for how, frozen in (("own", "True"), ("called", "False")):
        p = subprocess.run([sys.executable, "-c", code, how], cwd=ROOT, capture_output=True,
                           text=True, timeout=120)
        assert p.stdout.strip().splitlines()[-1] == f"frozen {frozen}", (how, p.stdout, p.stderr)
