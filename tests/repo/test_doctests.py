"""The examples in the docstrings (``>>>``) run and print what they show.

Every module of ``smoothdist`` and ``tracer`` is imported and its docstring examples run with
:mod:`doctest` (numbers as printed; ``NORMALIZE_WHITESPACE`` and ``ELLIPSIS`` allowed). The
documentation shows the same docstrings, so an example that drifts from the code fails here.
"""

import doctest
import importlib
import pkgutil

import numpy as np
import pytest

import smoothdist
import tracer

SKIP = {"tracer.__main__"}   # running it is running the command line


def _modules():
    names = []
    for pkg in (smoothdist, tracer):
        names.append(pkg.__name__)
        for info in pkgutil.walk_packages(pkg.__path__, prefix=pkg.__name__ + "."):
            if info.name not in SKIP:
                names.append(info.name)
    return sorted(names)


MODULES = _modules()
FLAGS = doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS


def _tests(name):
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    globs = {"np": np, **vars(module)}
    return [t for t in finder.find(module, name, globs=globs) if t.examples]


#: the modules whose docstrings hold examples (found at collection)
WITH_EXAMPLES = [name for name in MODULES if _tests(name)]


@pytest.mark.parametrize("name", WITH_EXAMPLES)
def test_docstring_examples(name):
    tests = _tests(name)
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    for t in tests:
        runner.run(t)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed in {name}"


def test_the_public_api_has_examples():
    """The entry points a reader meets first carry runnable examples."""
    documented = {t.name for name in ("smoothdist", "tracer.checks.notebook") for t in _tests(name)}
    assert "smoothdist.smooth_distance" in documented
    assert "tracer.checks.notebook.show_animation" in documented
