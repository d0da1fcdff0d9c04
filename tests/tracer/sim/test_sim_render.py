"""Rendering rigid bodies through per-object transforms (tracer.rendering.march pose columns).

A frame rendered with the bodies posed by a rigid transform of the query points must equal the
frame rendered from meshes whose vertices were transformed and whose trees were rebuilt.
"""

import numpy as np
import pytest

from smoothdist import DataMesh, SmoothDistanceField
from tracer.rendering.renderer import render
from tracer.scenes.scene import Scene, SceneObject, default_eps


def _rot(axis, angle):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def _tetra():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]) - 0.25
    F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    return V, F


def _wire():
    s = np.linspace(0, 2 * np.pi, 13)[:-1]
    V = np.c_[0.6 * np.cos(s), 0.6 * np.sin(s), 0.2 * np.sin(2 * s)]
    E = np.c_[np.arange(12), (np.arange(12) + 1) % 12]
    return V, E


def _scene(meshes, mode="smooth", size=48):
    objs = [SceneObject(name=f"o{i}", field=SmoothDistanceField(DataMesh(V, F)), alpha=12.0,
                        alpha_u=24.0, beta=0.5, offset=1 / 12.0) for i, (V, F) in enumerate(meshes)]
    sc = Scene(path="posed.json", camera_origin=np.array([0.3, 0.5, 4.0]),
               camera_dest=np.zeros(3), camera_up=np.array([0.0, 1, 0]), objects=objs,
               width=size, height=size, mode=mode, eps=1e-4)
    return sc


@pytest.mark.parametrize("mode", ["smooth", "exact"])
def test_posed_render_equals_rebuilt_render(mode):
    poses = [(_rot([1, 2, 0.5], 0.9), np.array([0.4, -0.2, 0.3])),
             (_rot([0, 1, 1], -2.1), np.array([-0.5, 0.3, -0.2]))]
    local = [_tetra(), _wire()]
    posed = render(_scene(local, mode), transforms=poses)
    moved = [(V @ R.T + t, F) for (V, F), (R, t) in zip(local, poses)]
    rebuilt = render(_scene(moved, mode))
    assert posed.hit.sum() > 100
    assert (posed.hit == rebuilt.hit).mean() > 0.995
    both = posed.hit & rebuilt.hit
    assert np.nanmax(np.abs(posed.depth[both] - rebuilt.depth[both])) < 1e-3
    assert np.abs(posed.rgb.astype(int) - rebuilt.rgb.astype(int)).max(axis=2)[both].mean() < 1.0


def test_identity_pose_is_bit_identical():
    local = [_tetra(), _wire()]
    eye = [(np.eye(3), np.zeros(3))] * 2
    a = render(_scene(local), transforms=eye)
    b = render(_scene(local))
    assert np.array_equal(a.hit, b.hit)
    assert np.array_equal(a.rgb, b.rgb)


def test_bad_transform_is_refused():
    with pytest.raises(ValueError, match="rotation"):
        render(_scene([_tetra()]), transforms=[(2 * np.eye(3), np.zeros(3))])
