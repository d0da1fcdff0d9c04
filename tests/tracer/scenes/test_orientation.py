"""Orientation from the data when the file cannot tell (issue 46, item 4): with ``up="auto"``
and the default front view, a flat object seen edge-on or a long one seen end-on is turned to
its largest outline; everything else keeps its file's convention, and the summary says which.

The outline areas are checked against analytic silhouettes (a cylinder's disc and rectangle,
a comb of plates), the chosen views against the rendered hit masks' extents.
"""
import math

import numpy as np
import pytest

import tracer
from smoothdist import DataMesh
from tracer.scenes.from_mesh import auto_orientation, outline_areas

trimesh = pytest.importorskip("trimesh")


def _data(m):
    return DataMesh(np.asarray(m.vertices), np.asarray(m.faces))


def test_outline_areas_are_silhouettes():
    """Cylinder r 0.5, h 2 along z: a disc of pi/4 along z, a 1 x 2 rectangle across. The
    grid (64 cells across 2 units, h = 1/32) counts whole cells: the cells the outline crosses
    add at most its perimeter times h (a 64-gon's area is 0.3 % below the disc's)."""
    cyl = trimesh.creation.cylinder(radius=0.5, height=2.0, sections=64)
    A = outline_areas(_data(cyl))
    h = 2.0 / 64
    assert 0.99 * math.pi / 4 <= A[2] <= math.pi / 4 + math.pi * h
    assert A[0] == pytest.approx(2.0, rel=0.05) and A[1] == pytest.approx(2.0, rel=0.05)
    # five parallel 1 x 1 plates across x: seen along x they cover one square, not five
    plates = trimesh.util.concatenate([
        trimesh.creation.box(extents=[0.02, 1.0, 1.0],
                             transform=trimesh.transformations.translation_matrix([x, 0, 0]))
        for x in np.linspace(0.0, 0.8, 5)])
    A = outline_areas(_data(plates))
    assert A[0] == pytest.approx(1.0, rel=0.05)
    # along y and z: five 0.02-wide strips (0.1), each widened by at most a cell (1/64)
    assert 0.1 <= A[1] <= 0.1 + 5 * 2 / 64 and 0.1 <= A[2] <= 0.1 + 5 * 2 / 64


def _hit_extent(res):
    rows, cols = np.flatnonzero(res.hit.any(axis=1)), np.flatnonzero(res.hit.any(axis=0))
    return cols.max() - cols.min() + 1, rows.max() - rows.min() + 1


def test_a_long_object_in_a_y_up_file_is_seen_from_its_side(tmp_path):
    path = tmp_path / "cylinder.obj"                      # along z in a y-up format
    trimesh.creation.cylinder(radius=0.3, height=2.0).export(path)
    s = tracer.mesh_scene(path, size=(48, 48))
    assert s.extra["orientation"].startswith("z up, from the data")
    w, h = _hit_extent(tracer.render(s))
    assert h > 2 * w                                       # the cylinder stands upright
    # the convention, when asked for: end-on, a disc
    w1, h1 = _hit_extent(tracer.render_mesh(path, size=(48, 48), up="y"))
    assert abs(w1 - h1) <= 2


def test_a_flat_object_in_a_z_up_file_is_seen_face_on(tmp_path):
    """A 'T' of two plates in the x-y plane, 0.1 thick, wider than tall, saved as STL (z up):
    its z-up front view looks along y at the edge; the y-up front view looks along z: the T
    upright."""
    bar = trimesh.creation.box(extents=[2.0, 0.3, 0.1])
    bar.apply_translation([0, 0.55, 0])
    stem = trimesh.creation.box(extents=[0.3, 1.0, 0.1])
    path = tmp_path / "tee.stl"
    trimesh.util.concatenate([bar, stem]).export(path)
    s = tracer.mesh_scene(path, size=(64, 64), shading="normals")
    assert s.extra["orientation"].startswith("y up, from the data")
    res = tracer.render(s)
    top = res.hit[: 32].sum(axis=1).max()     # the bar: a wide run of pixels in the upper half
    bottom = res.hit[40:].sum(axis=1).max()   # the stem: a narrow one lower down
    assert top > 2 * bottom > 0
    edge = tracer.render_mesh(path, size=(64, 64), up="z", shading="normals")
    assert edge.hit.sum() < 0.6 * res.hit.sum()


@pytest.mark.parametrize("make, name", [
    (lambda: trimesh.creation.capsule(height=2.0, radius=0.4), "capsule.stl"),
    (lambda: trimesh.creation.box(extents=[2.0, 1.5, 0.1]), "plate.obj"),
    (lambda: trimesh.creation.icosphere(), "ball.obj")])
def test_shapes_their_convention_shows_well_keep_it(tmp_path, make, name):
    path = tmp_path / name
    make().export(path)
    s = tracer.mesh_scene(path, size=(32, 32))
    assert s.extra["orientation"].endswith("(the file's convention)")
    same = tracer.mesh_scene(path, size=(32, 32), up="z" if name.endswith(".stl") else "y")
    np.testing.assert_array_equal(s.camera_origin, same.camera_origin)


def test_side_views_when_neither_front_view_shows_the_data(tmp_path):
    """A plate in the y-z plane (thin along x) in a y-up OBJ: both conventions' front views
    (along z, along y) see its edge; the z-up side view (along x) sees its face."""
    plate = trimesh.creation.box(extents=[0.05, 1.0, 1.5])
    up, view, why = auto_orientation(_data(plate), "y")
    assert up == "z" and why.startswith("looking along x with z up, from the data")
    np.testing.assert_array_equal(view[0], [1.0, 0, 0])
    np.testing.assert_array_equal(view[1], [0, 0, 1.0])
    path = tmp_path / "plate.obj"
    plate.export(path)
    face = tracer.render_mesh(path, size=(32, 32), shading="normals")
    edge = tracer.render_mesh(path, size=(32, 32), shading="normals", up="y")
    w, h = _hit_extent(face)                 # the 1 x 1.5 face, upright (thickened a little
    assert 1.1 < h / w < 2.0                 # by the surface's offset)
    w, h = _hit_extent(edge)                 # the edge: a thin upright strip
    assert h / w > 2.5
