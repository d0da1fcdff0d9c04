"""tracer's public names, each from the module that defines it: the one list of them.

``tracer/__init__.py`` reads this file and imports each name on first use (``import tracer``
stays light); editors and type checkers read it to go to each definition (the pattern of
scikit-image's ``__init__.pyi``). Add a public name here, and only here.
"""

from tracer.checks.imagediff import check_images as check_images
from tracer.checks.notebook import show_animation as show_animation
from tracer.rendering.frame import RenderResult as RenderResult
from tracer.rendering.lighting import Lighting as Lighting
from tracer.rendering.renderer import render as render
from tracer.scenes.from_mesh import mesh_scene as mesh_scene
from tracer.scenes.from_mesh import render_mesh as render_mesh
from tracer.scenes.scene import Scene as Scene
from tracer.scenes.scene import SceneObject as SceneObject
from tracer.scenes.scene import load_scene as load_scene
from tracer.scenes.scene import scene_from_field as scene_from_field

__all__ = ["Lighting", "RenderResult", "Scene", "SceneObject", "check_images", "load_scene",
           "mesh_scene", "render", "render_mesh", "scene_from_field", "show_animation"]
