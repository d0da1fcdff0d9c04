"""Public names of a package read from its stub, each imported on first use.

A package's ``__init__.pyi`` lists its public names once, each as ``from MODULE import NAME as
NAME`` from the module that defines it; :func:`attach_stub` turns that list into the
package's ``__getattr__``, ``__dir__`` and ``__all__`` (the pattern of scikit-image's
``lazy_loader.attach_stub``, in a few lines). Editors and type checkers read the same stub,
so "go to definition" reaches the defining module, while ``import tracer`` stays light.
"""

import ast
import importlib
import os

__all__ = ["attach_stub", "stub_names"]


def stub_names(stub):
    """``{name: module}`` of the ``from MODULE import NAME as NAME`` lines of the stub file
    ``stub`` (a path)."""
    with open(stub, encoding="utf-8") as fh:
        tree = ast.parse(fh.read(), filename=stub)
    return {a.asname or a.name: node.module for node in tree.body
            if isinstance(node, ast.ImportFrom) for a in node.names}


def attach_stub(package, package_file):
    """``(__getattr__, __dir__, __all__)`` for the package named ``package`` whose
    ``__init__.py`` is ``package_file``, from the ``__init__.pyi`` beside it."""
    names = stub_names(os.path.join(os.path.dirname(package_file), "__init__.pyi"))

    def __getattr__(name):
        if name in names:
            return getattr(importlib.import_module(names[name]), name)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__():
        return sorted(set(names) | set(importlib.import_module(package).__dict__))

    return __getattr__, __dir__, sorted(names)
