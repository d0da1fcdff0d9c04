"""The old import paths of tracer's modules that moved into its rooms (issue 33) and of the
studies' runner and frames, kept for one release (the deprecation policy:
``docs/guide/deprecation.md``).

:data:`MOVED` maps each old path to the module now there; the import hook, installed by
``import tracer``, answers an import of an old path with the new module itself after one
``DeprecationWarning`` at the importing line (``from tracer.camera import primary_rays``
works, and ``tracer.camera is tracer.rendering.camera``). The hook is a copy of
``smoothdist/_moved.py``'s (tracer uses only smoothdist's public modules). Old paths that are
now public names of a package cannot be modules again and are gone without a warning:
``tracer.render`` (the function), ``tracer.mesh_scene`` (the function) and
``smoothdist.mesh_distance`` (the function; the module is :mod:`smoothdist.whole_mesh`).
"""

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

#: old path -> new path; an old path goes in the release after the one that moved it
MOVED = {
    **{f"tracer.{m}": f"tracer.rendering.{m}" for m in (
        "camera", "film", "frame", "gpu_render", "lighting", "march", "ripple", "shading",
        "threads")},
    **{f"tracer.{m}": f"tracer.scenes.{m}" for m in (
        "from_mesh", "scene", "scene_schema", "settings")},
    **{f"tracer.{m}": f"tracer.checks.{m}" for m in ("compare", "imagediff", "notebook")},
    "tracer.studies.runner": "tracer.runner",
    "tracer.studies.frames": "tracer.sim.frames",
}
#: where a user of an old path finds the public names
PUBLIC = "the public names live in tracer (tracer.render, tracer.Scene, ...)"


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
