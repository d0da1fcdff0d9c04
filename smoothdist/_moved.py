"""The old import paths of the kernel modules that moved into ``smoothdist._kernels``.

Each old module (``smoothdist/query.py``, ...) is three lines: it calls :func:`forward`, which
warns once (a module is imported once per process) with a ``DeprecationWarning`` pointing at the
importing line, and returns the module ``__getattr__`` and ``__dir__`` that hand out the new
module's names, ``_private`` ones included. The old paths go in the release after 0.1.
"""

import importlib
import warnings

#: the modules that moved, ``smoothdist.<name>`` -> ``smoothdist._kernels.<name>``
MOVED = ("closest_point", "closest_pair", "box_distance", "box_moment", "weights", "spacing",
         "bvh", "query", "exact_query", "mesh_query", "mesh_moment")


def forward(old, new):
    """Warn that module ``old`` is now ``new``; return ``(__getattr__, __dir__)`` for ``old``."""
    warnings.warn(f"{old} is deprecated: the kernels moved to the private {new}; the public names "
                  "live in smoothdist and smoothdist.kernels (this path goes in the next release)",
                  DeprecationWarning, stacklevel=3)
    module = importlib.import_module(new)

    def __getattr__(name):
        if name == "__all__":  # ``from old import *``: the new module's public names
            return getattr(module, "__all__", [n for n in vars(module) if n[:1] != "_"])
        try:
            return getattr(module, name)
        except AttributeError:
            msg = f"module {old!r} (now {new!r}) has no attribute {name!r}"
            raise AttributeError(msg) from None

    def __dir__():
        return dir(module)

    return __getattr__, __dir__
