"""The public names of ``tracer`` and ``tracer.sim`` are listed once, in each package's stub
(``__init__.pyi``), each from the module that defines it; the packages load them on first use
(:mod:`tracer.lazy`). Issue 50 item 3: "go to definition" reaches the definition."""

import importlib
import subprocess
import sys
from pathlib import Path

import pytest

import tracer
import tracer.sim
from tracer.lazy import stub_names

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("package", [tracer, tracer.sim])
def test_the_stub_lists_every_public_name_from_its_definition(package):
    names = stub_names(Path(package.__file__).with_name("__init__.pyi"))
    assert sorted(names) == package.__all__ and len(names) >= 3
    for name, module in names.items():
        obj = getattr(package, name)
        assert obj is getattr(importlib.import_module(module), name)
        # the module named is where it is defined, not a module that re-exports it
        assert getattr(obj, "__module__", module) == module, (name, obj.__module__, module)
        assert name in dir(package)
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        package.nope  # noqa: B018


def test_the_stub_is_package_data():
    text = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    assert '"tracer" = ["__init__.pyi"]' in text and '"tracer.sim" = ["__init__.pyi"]' in text


def test_import_tracer_stays_light():
    """``import tracer`` loads none of its rooms (nor numba) until a name is used."""
    code = ("import sys, tracer; print(sorted(m for m in sys.modules if m.startswith('tracer.')"
            " or m == 'numba'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=ROOT, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "['tracer._moved', 'tracer.lazy']"
