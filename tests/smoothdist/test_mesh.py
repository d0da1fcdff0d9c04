"""DataMesh: file loading (OBJ with ``l``/``f``, OFF, PLY, STL), primitive-kind conversion,
repairs (MeshRepairWarning), input validation (ValueError naming the problem), and the
per-primitive weight data against an independent valence count."""

import os
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh

import naive
import smoothdist
from smoothdist import DataMesh, MeshRepairWarning, SmoothDistanceField
from smoothdist._kernels import weights as W

DATA = Path(__file__).resolve().parents[1] / "data"
TRI = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.2]])
TRI_F = np.array([[0, 1, 2], [1, 3, 2]])


def write(path, text):
    path.write_text(text)
    return path


# ----------------------------------------------------------------------------- loading
def test_obj_lines_load_as_edges(tmp_path):
    p = write(tmp_path / "curve.obj",
              "# a polyline and a single segment\n"
              "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 5 5 5\nv 6 5 5\n"
              "l 1 2 3 4\n"          # a 3-segment polyline
              "l 5/1 6/2\n")         # texture indices are ignored
    m = DataMesh.load(p)
    assert m.kind == "edges"
    assert m.triangles.shape == (0, 3) and m.points.size == 0
    np.testing.assert_array_equal(np.sort(m.edges, axis=1), [[0, 1], [1, 2], [2, 3], [4, 5]])
    assert m.V.shape == (6, 3)
    np.testing.assert_array_equal(m.V[m.edges[3]], [[5, 5, 5], [6, 5, 5]])


def test_obj_two_vertex_faces_are_edges(tmp_path):
    """The authors' files (and libigl's writer) store an edge as ``f a b``: it loads as the
    same edge as ``l a b``."""
    f = DataMesh.load(write(tmp_path / "f.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2\nf 2/5 3\n"))
    ln = DataMesh.load(write(tmp_path / "l.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nl 1 2\nl 2 3\n"))
    assert f.kind == ln.kind == "edges"
    np.testing.assert_array_equal(np.sort(f.edges, axis=1), np.sort(ln.edges, axis=1))
    np.testing.assert_array_equal(f.V, ln.V)


def test_obj_faces_polygons_negative_indices_and_mixed(tmp_path):
    p = write(tmp_path / "mixed.obj",
              "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 3\nvn 0 0 1\n"
              "f 1//1 2//1 3//1 4//1\n"  # a quad, fanned into 2 triangles
              "l -1 -5\n")               # negative (relative) indices: v5 -> v1
    m = DataMesh.load(p)
    assert m.kind == "mixed"
    assert m.triangles.shape == (2, 3) and m.edges.shape == (1, 2)
    np.testing.assert_array_equal(m.triangles, [[0, 1, 2], [0, 2, 3]])
    np.testing.assert_array_equal(np.sort(m.edges[0]), [0, 4])
    assert m.as_kind("triangles").num_primitives == 2
    assert m.as_kind("edges").edges.shape == (5 + 1, 2)   # 5 unique quad-fan edges + line
    assert m.as_kind("points").points.size == 5


def test_obj_vertices_only_is_point_cloud(tmp_path):
    p = write(tmp_path / "cloud.obj", "v 0 0 0\nv 1 0 0\nv 0 2 0\n")
    m = DataMesh.load(p)
    assert m.kind == "points" and m.points.size == 3


def test_off_loads(tmp_path):
    p = write(tmp_path / "quad.off",
              "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0.2\n3 0 1 2\n3 1 3 2\n")
    m = DataMesh.load(p)
    assert m.kind == "triangles" and m.triangles.shape == (2, 3) and m.V.shape == (4, 3)
    np.testing.assert_allclose(np.sort(m.V, axis=0), np.sort(TRI, axis=0))


def test_ply_loads_mesh_and_point_cloud(tmp_path):
    p = write(tmp_path / "quad.ply",
              "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
              "property float z\nelement face 2\nproperty list uchar int vertex_indices\n"
              "end_header\n0 0 0\n1 0 0\n0 1 0\n1 1 0.2\n3 0 1 2\n3 1 3 2\n")
    m = DataMesh.load(p)
    assert m.kind == "triangles" and m.triangles.shape == (2, 3)
    pts = np.random.default_rng(1).random((25, 3))
    trimesh.PointCloud(pts).export(tmp_path / "cloud.ply")
    c = DataMesh.load(tmp_path / "cloud.ply")
    assert c.kind == "points" and c.points.size == 25
    np.testing.assert_allclose(np.sort(c.V, axis=0), np.sort(pts, axis=0), rtol=1e-6)


def test_xyz_loads_with_white_space_or_commas(tmp_path):
    pts = np.random.default_rng(2).normal(size=(7, 3))
    rows = [f"{x!r} {y!r} {z!r}" for x, y, z in pts.tolist()]
    spaced = DataMesh.load(write(tmp_path / "spaced.xyz", "\n".join(rows) + "\n"))
    # a header, commas with or without spaces, a comment, a blank line, extra columns
    commas = ["x,y,z"] + [f"{x!r},{y!r}, {z!r}" for x, y, z in pts[:4].tolist()] + ["# scan 2", ""] \
        + [f"{x!r},{y!r},{z!r},0.0,0.0,1.0" for x, y, z in pts[4:].tolist()]
    comma = DataMesh.load(write(tmp_path / "comma.xyz", "\n".join(commas)))
    for m in (spaced, comma):
        assert m.kind == "points" and m.points.size == 7
        np.testing.assert_array_equal(m.V[m.points], pts)   # repr round-trips exactly
    with pytest.raises(ValueError, match=r"bad\.xyz:2: malformed XYZ row '1,2'"):
        DataMesh.load(write(tmp_path / "bad.xyz", "0,0,0\n1,2\n"))


def test_stl_loads_and_merges_quietly(tmp_path):
    box = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
    box.export(tmp_path / "box.stl")
    with warnings.catch_warnings():
        warnings.simplefilter("error", MeshRepairWarning)   # STL soups merge silently
        m = DataMesh.load(tmp_path / "box.stl")
    assert m.kind == "triangles" and m.triangles.shape == (12, 3) and m.V.shape == (8, 3)
    np.testing.assert_allclose(SmoothDistanceField(m).exact_distance([[0, 0, 5.0]])[0], [3.5])


def test_load_kind_argument_and_top_level_loader(octopus):
    e = DataMesh.load(DATA / "octopus_low.obj", kind="edges")
    assert e.kind == "edges" and e.edges.shape[0] == octopus.as_kind("edges").edges.shape[0]
    p = smoothdist.load_mesh(DATA / "octopus_low.obj", kind="points")
    assert p.kind == "points" and p.points.size == 451


# ----------------------------------------------------------------------------- counts
def independent_unique_edges(T):
    return {tuple(sorted((int(a), int(b)))) for t in T for a, b in ((t[0], t[1]), (t[1], t[2]),
                                                                    (t[2], t[0]))}


def test_octopus_counts(octopus):
    assert octopus.V.shape == (451, 3)
    assert octopus.as_kind("triangles").triangles.shape == (898, 3)
    E = octopus.as_kind("edges").edges
    # closed 2-manifold, genus 0: V - E + F = 2
    assert E.shape[0] == 451 + 898 - 2
    assert {tuple(e) for e in np.sort(E, axis=1)} == independent_unique_edges(octopus.triangles)
    assert octopus.as_kind("points").points.size == 451


def test_trefoil_counts(trefoil):
    assert trefoil.kind == "edges" and trefoil.edges.shape == (287, 2) and trefoil.V.shape[0] == 287
    assert np.all(np.bincount(trefoil.edges.ravel()) == 2)
    assert trefoil.as_kind("points").points.size == 287
    with pytest.raises(ValueError, match="no triangles"):
        trefoil.as_kind("triangles")


def test_bunny_counts(bunny):
    assert bunny.V.shape == (3485, 3)
    F = bunny.as_kind("triangles")
    assert F.triangles.shape == (6966, 3)
    E = bunny.as_kind("edges")
    expect = independent_unique_edges(bunny.triangles)
    assert E.edges.shape[0] == len(expect) == 10449
    assert {tuple(e) for e in np.sort(E.edges, axis=1)} == expect
    assert bunny.as_kind("points").points.size == 3485
    for k, n in (("points", 3485), ("edges", 10449), ("triangles", 6966)):
        assert SmoothDistanceField(bunny.as_kind(k)).num_primitives == n


def test_mixed_construction(mixed_mesh):
    m = mixed_mesh
    assert m.kind == "mixed"
    assert m.num_primitives == m.points.size + m.edges.shape[0] + m.triangles.shape[0]
    assert SmoothDistanceField(m).num_primitives == m.num_primitives
    used = np.unique(np.concatenate([m.points, m.edges.ravel(), m.triangles.ravel()]))
    np.testing.assert_array_equal(np.sort(m.as_kind("points").points), used)
    assert m.as_kind("mixed") is m
    with pytest.raises(ValueError, match="kind"):
        m.as_kind("tets")


def test_min_edge_length(icosphere, point_cloud, circle):
    V, T = icosphere.V, icosphere.triangles
    L = [np.linalg.norm(V[t[i]] - V[t[(i + 1) % 3]]) for t in T for i in range(3)]
    assert icosphere.min_edge_length() == pytest.approx(min(L), rel=1e-14)
    assert point_cloud.min_edge_length() is None
    Lc = np.linalg.norm(circle.V[circle.edges[:, 0]] - circle.V[circle.edges[:, 1]], axis=1)
    assert circle.min_edge_length() == pytest.approx(Lc.min(), rel=1e-14)


# ----------------------------------------------------------------------------- repairs
def test_duplicate_vertices_are_merged_with_warning():
    V = np.concatenate([TRI, TRI[1:2]])                    # vertex 4 duplicates vertex 1
    F = np.array([[0, 1, 2], [4, 3, 2]])
    with pytest.warns(MeshRepairWarning, match="duplicated vertices"):
        m = DataMesh(V, F)
    assert m.V.shape == (4, 3) and m.triangles.shape == (2, 3)
    # the two triangles now share an edge: same geometry, shared vertex index
    assert len(set(m.triangles[0]) & set(m.triangles[1])) == 2
    with pytest.raises(ValueError, match="duplicated vertices"):
        DataMesh(V, F, repair=False)


def test_duplicate_points_warn(point_cloud):
    V = np.concatenate([point_cloud.V, point_cloud.V[:3]])
    with pytest.warns(MeshRepairWarning, match="duplicated"):
        m = DataMesh(V)
    assert m.points.size == point_cloud.points.size


def test_zero_length_edges_dropped_with_warning():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]])
    with pytest.warns(MeshRepairWarning, match="zero-length edges"):
        m = DataMesh(V, [[0, 1], [1, 1], [1, 2]])
    assert m.edges.shape == (2, 2)
    with pytest.raises(ValueError, match="zero-length"):
        DataMesh(V, [[0, 1], [2, 2]], repair=False)


def test_zero_area_triangles_dropped_with_warning():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]])
    with pytest.warns(MeshRepairWarning, match="zero-area triangles"):
        m = DataMesh(V, [[0, 1, 2], [0, 1, 3]])             # 0, 1, 3 are collinear
    assert m.triangles.shape == (1, 3)
    with pytest.raises(ValueError, match="zero-area"):
        DataMesh(V, [[0, 1, 2], [0, 1, 3]], repair=False)


def test_duplicate_triangles_dropped_with_warning():
    with pytest.warns(MeshRepairWarning, match="duplicated triangles"):
        m = DataMesh(TRI, [[0, 1, 2], [1, 3, 2], [2, 0, 1]])
    assert m.triangles.shape == (2, 3)


def test_clean_mesh_emits_no_warning(octopus):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        DataMesh(octopus.V, octopus.triangles)
        DataMesh(TRI, TRI_F)


def test_all_degenerate_raises():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]])
    with pytest.raises(ValueError, match="no valid primitives"):
        DataMesh(V, [[0, 1, 2]])


# ----------------------------------------------------------------------------- validation
@pytest.mark.parametrize("V,F,word", [
    ([[0.0, 0, 0], [1, float("nan"), 0], [0, 1, 0]], [[0, 1, 2]], "NaN"),
    ([[0.0, 0, 0], [1, float("inf"), 0], [0, 1, 0]], [[0, 1, 2]], "infinite"),
    (np.zeros((0, 3)), None, "no vertices"),
    (TRI, np.zeros((0, 3), dtype=int), "no rows"),
    (TRI, [[0, 1, 4]], "out of range"),
    (TRI, [[0, 1, 7], [1, 2, 3]], "out of range"),
    (TRI, [[0, -1, 2]], "negative"),
    (TRI[:, :2], [[0, 1, 2]], "shape"),
    (TRI, [[0, 1, 2, 3]], "shape"),
    (TRI, [[[0, 1, 2]]], "shape"),
    (TRI, [[0, 1.5, 2]], "integer"),
    (TRI, [["a", "b", "c"]], "integer"),
])
def test_bad_mesh_input_raises(V, F, word):
    with pytest.raises(ValueError, match=word):
        DataMesh(V, F)
    with pytest.raises(ValueError, match=word):
        smoothdist.smooth_distance([[0.0, 0, 1]], V, F, alpha=1.0)


def test_bad_mixed_input_raises():
    with pytest.raises(ValueError, match="edges"):
        DataMesh(TRI, edges=[[0, 1, 2]])
    with pytest.raises(ValueError, match="points"):
        DataMesh(TRI, points=[0, 9])
    with pytest.raises(ValueError, match="triangles"):
        DataMesh(TRI, triangles=[[0, 1]])
    with pytest.raises(ValueError, match="no primitives"):
        DataMesh(TRI, points=[], edges=np.zeros((0, 2), dtype=int))
    with pytest.raises(ValueError, match="only together"):
        SmoothDistanceField(DataMesh(TRI, TRI_F), TRI_F)


def test_missing_file(tmp_path):
    with pytest.raises(ValueError, match="not found"):
        DataMesh.load(tmp_path / "nope.obj")


def test_folder_instead_of_file(tmp_path):
    (tmp_path / "dir.obj").mkdir()
    with pytest.raises(ValueError, match="folder"):
        DataMesh.load(tmp_path / "dir.obj")


@pytest.mark.parametrize("ext", [".obj", ".off", ".ply", ".stl"])
def test_empty_file(tmp_path, ext):
    p = tmp_path / f"empty{ext}"
    p.write_bytes(b"")
    with pytest.raises(ValueError, match="empty"):
        DataMesh.load(p)


@pytest.mark.parametrize("name", ["mesh.abc", "mesh", "mesh.obj.bak"])
def test_unsupported_extension(tmp_path, name):
    p = write(tmp_path / name, "v 0 0 0\n")
    with pytest.raises(ValueError, match="unsupported"):
        DataMesh.load(p)


@pytest.mark.parametrize("text,word", [
    ("v 0 0 0\nv 1 2 x\n", "malformed"),
    ("v 0 0 0\nv 1 0 0\nv 0 1\n", "malformed"),
    ("v 0 0 0\nv 1 0 0\nf 1\n", "malformed"),
    ("v 0 0 0\nv 1 0 0\nl 1\n", "malformed"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "out of range"),
    ("v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", "NaN"),
    ("# nothing but a comment\n", "no vertices"),
])
def test_malformed_obj(tmp_path, text, word):
    with pytest.raises(ValueError, match=word):
        DataMesh.load(write(tmp_path / "bad.obj", text))


@pytest.mark.parametrize("ext", [".off", ".ply", ".stl", ".obj"])
def test_garbage_file_raises_value_error_naming_the_file(tmp_path, ext):
    """Random bytes must give a ValueError whose message says which file could not be read.

    Regression: ``mesh.read_mesh_file`` used to re-raise trimesh's own ValueErrors unchanged
    (``except ValueError: raise``), so a garbage .off gave "not enough values to unpack
    (expected 3, got 1)" and a garbage .ply "Not a ply file!", with no file name.
    """
    p = tmp_path / f"garbage{ext}"
    p.write_bytes(np.random.default_rng(7).integers(0, 256, 600, dtype=np.uint8).tobytes())
    with pytest.raises(ValueError) as info:
        DataMesh.load(p)
    assert os.fspath(p) in str(info.value)


# ----------------------------------------------------------------------------- weight data
WEIGHT_MESHES = ("circle", "segment_star", "icosphere", "cube", "mixed_mesh", "nonmanifold_mesh",
                 "octopus", "trefoil")


@pytest.mark.parametrize("name", WEIGHT_MESHES)
def test_weight_data_matches_independent_valences(request, zoo, name):
    mesh = zoo[name] if name in zoo else request.getfixturevalue(name)
    A, ec, ewhi, tc, twhi = mesh.weight_data()
    A_ref, ev, tv, te = naive.valences(mesh)
    assert A == A_ref
    assert ec.shape == (mesh.edges.shape[0], 5) and tc.shape == (mesh.triangles.shape[0], 13)
    t = np.linspace(0.0, 1.0, 20001)
    for i, (n0, n1) in enumerate(ev):
        np.testing.assert_allclose(ec[i], W.edge_weight_coefficients(n0, n1), rtol=0, atol=0)
        peak = max(1.0, A * naive.edge_poly(ec[i], t)[0].max())
        assert peak <= ewhi[i] * (1 + 1e-12) and ewhi[i] == pytest.approx(peak, rel=1e-6)
    # triangle: sampled maximum on the (independent) grid i/200, j/200, i + j <= 200
    i, j = np.meshgrid(np.arange(201), np.arange(201), indexing="ij")
    keep = i + j <= 200
    s, u = i[keep] / 200.0, j[keep] / 200.0
    cache = {}
    for k, (v, e) in enumerate(zip(tv, te)):
        np.testing.assert_allclose(tc[k], W.triangle_weight_coefficients(v, e), rtol=0, atol=0)
        if (v, e) not in cache:
            cache[(v, e)] = max(1.0, A * naive.triangle_poly(tc[k], s, u)[0].max())
        assert twhi[k] == pytest.approx(cache[(v, e)], rel=1e-12)
    # the field's bound is the largest clamp (it may be below A for triangle meshes, whose
    # polynomial peaks at (v - 1)/v, and above A for edges with unequal end valences)
    assert SmoothDistanceField(mesh).weight_bound == max([1.0, *ewhi, *twhi])


def test_naive_triangle_polynomial_matches_library_evaluator(rng):
    """Cross-check of the test reference's own monomial evaluator."""
    s, t = rng.random(500), rng.random(500)
    for v, e in ((3, 2), (6, 2), (4, 4), (2, 1), (1, 1)):
        c = W.triangle_weight_coefficients(v, e)
        w, ws, wt = naive.triangle_poly(c, s, t)
        np.testing.assert_allclose(w, W._triangle_poly(c, s, t), rtol=1e-12, atol=1e-13)
        h = 1e-6
        np.testing.assert_allclose(ws, (W._triangle_poly(c, s + h, t)
                                        - W._triangle_poly(c, s - h, t)) / (2 * h), atol=1e-6)
        np.testing.assert_allclose(wt, (W._triangle_poly(c, s, t + h)
                                        - W._triangle_poly(c, s, t - h)) / (2 * h), atol=1e-6)


def test_point_cloud_weights_are_one(point_cloud):
    A, ec, ewhi, tc, twhi = point_cloud.weight_data()
    assert A == 1.0 and ec.shape == (0, 5) and tc.shape == (0, 13)
    assert SmoothDistanceField(point_cloud).weight_bound == 1.0


@pytest.mark.parametrize("text", [
    "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0.2\n3 0 1 2\n3 1 3 2\n",
    "OFF 4 2 0\n# a comment\n0 0 0\n1 0 0 # trailing\n0 1 0\n1 1 0.2\n3 0 1 2 255 0 0\n"
    "3 1 3 2 0 255 0\n",
    "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0.2\n4 0 1 3 2\n",
])
def test_ascii_off_reader_matches_trimesh(tmp_path, text):
    """Our ASCII OFF reader (no trimesh import) reads what trimesh reads."""
    from smoothdist import mesh as mesh_mod
    p = write(tmp_path / "m.off", text)
    V, E, T, _ = mesh_mod.read_mesh_file(p)
    V2, E2, T2 = mesh_mod._read_with_trimesh(os.fspath(p), ".off")
    np.testing.assert_array_equal(V, V2)
    np.testing.assert_array_equal(np.sort(np.sort(T, 1), 0), np.sort(np.sort(T2, 1), 0))
    assert E.shape == (0, 2)


def test_ascii_off_reader_on_the_bunny():
    from smoothdist import mesh as mesh_mod
    path = os.fspath(Path(__file__).resolve().parents[2] / "scenes" / "data" / "bunny.off")
    V, E, T, _ = mesh_mod.read_mesh_file(path)
    V2, E2, T2 = mesh_mod._read_with_trimesh(path, ".off")
    np.testing.assert_array_equal(V, V2)
    np.testing.assert_array_equal(T, T2)


def test_needs_trimesh_says_which_files_trimesh_reads(tmp_path, monkeypatch):
    """``needs_trimesh`` (the command line checks for trimesh before any work with it) is True
    exactly for the files that ``read_mesh_file`` hands to trimesh."""
    from smoothdist import mesh as mesh_mod

    calls = []

    def trimesh_reader(path, ext):
        calls.append(path)
        raise ImportError("not read here")

    monkeypatch.setattr(mesh_mod, "_read_with_trimesh", trimesh_reader)
    files = {"m.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "m.xyz": "0 0 0\n1 0 0\n",
             "m.off": "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
             "b.off": "OFF BINARY\n3 1 0\n", "m.ply": "ply\n", "m.stl": "solid m\n",
             "m.glb": "glTF", "m.gltf": "{}", "empty.stl": "", "m.txt": "text"}
    for name, text in files.items():
        write(tmp_path / name, text)
    (tmp_path / "folder.ply").mkdir()
    for name in [*files, "folder.ply", "missing.ply"]:
        calls.clear()
        try:
            mesh_mod.read_mesh_file(tmp_path / name)
        except (ImportError, ValueError):
            pass
        assert mesh_mod.needs_trimesh(tmp_path / name) == bool(calls), name
    assert mesh_mod.needs_trimesh(tmp_path / "m.ply") and not mesh_mod.needs_trimesh(
        tmp_path / "m.off")


@pytest.mark.parametrize("text,word", [
    ("OFF\n3 1 0\n0 0 0\n1 0 0\n", "vertices announced"),
    ("OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "faces announced"),
    ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1\n", "face 0"),
    ("OFF\nx 1 0\n", "malformed OFF"),
])
def test_malformed_ascii_off(tmp_path, text, word):
    with pytest.raises(ValueError, match=word):
        DataMesh.load(write(tmp_path / "bad.off", text))


def test_triangle_normals_are_numpys_cross_bit_for_bit():
    """Issue 60: the repair's zero-area test and the feature sizes' area weights take the
    triangles' normals without the gathered (t, 3, 3) corners; the values are the bits of
    ``np.cross`` of the same edge vectors (the same products, in the same order), so a
    triangle dropped or sampled before is dropped or sampled now."""
    from smoothdist.mesh import triangle_normals

    rng = np.random.default_rng(11)
    V = rng.normal(size=(500, 3)) * rng.uniform(1e-6, 1e6, (500, 1))
    T = rng.integers(0, 500, (2000, 3))
    ref = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    np.testing.assert_array_equal(triangle_normals(V, T), ref)
    assert triangle_normals(V, T[:0]).shape == (0, 3)
