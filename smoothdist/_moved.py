"""The old import paths of the modules that moved, kept for one release (the deprecation
policy: ``docs/guide/deprecation.md``).

:data:`MOVED` maps each old path to the module now there. An import hook
(:class:`MovedModules`, installed by ``import smoothdist``) answers an import of an old path
with the new module itself, after one ``DeprecationWarning`` at the importing line: ``import
old``, ``from old import name`` (``_private`` names too) and ``from old import *`` work as
before, and ``old is new``. There are no files at the old paths, so nothing can import them by
accident, and the table is the whole list. ``tracer/_moved.py`` is the same hook for tracer's
paths (a copy: tracer uses only smoothdist's public modules; ``tests/repo/test_moved_modules.py``
checks both alike).
"""

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

#: old path -> new path; an old path goes in the release after the one that moved it
MOVED = {f"smoothdist.{name}": f"smoothdist._kernels.{name}" for name in (
    "closest_point", "closest_pair", "box_distance", "box_moment", "weights", "spacing", "bvh",
    "query", "exact_query", "mesh_query", "mesh_moment")}
#: where a user of an old path finds the public names
PUBLIC = "the public names live in smoothdist and smoothdist.kernels"


class MovedModules(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Import hook: an old path of :data:`MOVED` imports as its new module, with a warning."""

    def __init__(self, moved, public):
        self.moved, self.public = moved, public

    def find_spec(self, fullname, path=None, target=None):
        if fullname not in self.moved:
            return None
        return importlib.util.spec_from_loader(fullname, self)

    def create_module(self, spec):
        return None                     # a placeholder module, replaced in exec_module

    def exec_module(self, module):
        old = module.__name__
        # stacklevel 2 is the import statement: the warnings module skips importlib's frames
        warnings.warn(f"{old} is deprecated: it moved to {self.moved[old]}; {self.public} (the "
                      "old path goes in the next release)", DeprecationWarning, stacklevel=2)
        # the import returns what sys.modules holds at the end: the new module itself
        sys.modules[old] = importlib.import_module(self.moved[old])


def install(moved, public):
    """Put a :class:`MovedModules` hook for ``moved`` first in ``sys.meta_path`` (once): the
    old paths are its alone, whatever else an installation puts on the path."""
    if not any(isinstance(f, MovedModules) and f.moved is moved for f in sys.meta_path):
        sys.meta_path.insert(0, MovedModules(moved, public))


install(MOVED, PUBLIC)
