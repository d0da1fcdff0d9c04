"""Shared fixtures for the smoothdist tests: seeded randomness, procedural and real meshes.

* ``rng``: a seeded ``numpy.random.Generator`` (fresh per test).
* Procedural meshes (session scoped :class:`smoothdist.DataMesh` objects): ``icosphere``,
  ``cube``, ``circle`` (closed polyline), ``point_cloud``, ``mixed_mesh`` (triangles + edges +
  points over one vertex array), ``nonmanifold_mesh`` (a "book" of triangles on one edge,
  isolated triangles and a bow-tie: the weight clamp is active there), ``segment_star``
  (edges with unequal end valences, whose weight peaks above ``A``).
* ``zoo``: all of the above in a dict, by name, for parametrised tests.
* ``octopus``, ``trefoil``: small real meshes shipped in ``tests/data`` (always available).
* ``shared_data``: the project's ``../shared/data`` folder; tests using it are skipped when it
  is absent (CI has it, users usually do not).

Where that folder exists and ``$SMOOTHDIST_DATA`` is not set, it is named there as the folder
of local copies of :mod:`tracer.datasets` (it holds every registered file, checked the same
way), so that the tests that run the benchmarks and the reproduction read it instead of
downloading; without it they download on first use, or say which data is missing.
"""

import os
from pathlib import Path

import numpy as np
import pytest
import trimesh

from smoothdist import DataMesh

TESTS = Path(__file__).resolve().parent
DATA = TESTS / "data"
SEED = 20220722

#: the project's data folder beside the repository (our machines and CI have it; users do not)
SHARED_DATA = (TESTS.parent / ".." / "shared" / "data").resolve()
if (SHARED_DATA / "README.md").is_file():
    os.environ.setdefault("SMOOTHDIST_DATA", str(SHARED_DATA))
#: no child processes compiling a first render's film kernels beside the test workers (they
#: share a cold cache at the start of a CI run, and the workers already use every core);
#: tests/tracer/scenes/test_compile_ahead.py tests them on purpose
os.environ.setdefault("TRACER_COMPILE_AHEAD", "off")

ZOO_NAMES = ("point_cloud", "circle", "segment_star", "icosphere", "cube", "mixed_mesh",
             "nonmanifold_mesh")

#: the files that take longest on CI's two cores (their tests' seconds summed, largest first,
#: from a run with ``--durations=0``), run first: ``.ci/run`` hands whole files to its two
#: workers in collection order (``--dist loadfile --no-loadscope-reorder``), so a long file
#: taken last would keep one worker busy while the other waits. The rest keep their order.
LONG_FILES = ("repo/test_readme.py", "tracer/reproduce/test_reproduce.py", "repo/test_docs.py",
              "tracer/scenes/test_compile_ahead.py", "smoothdist/test_cuda_sim.py",
              "smoothdist/test_warmup.py", "tracer/test_cli_errors.py",
              "repo/test_coldstart_counts.py", "smoothdist/test_whole_mesh_continuity.py",
              "tracer/sim/test_sim_compile_ahead.py")


def pytest_collection_modifyitems(config, items):
    """The files of :data:`LONG_FILES` first, in its order; the order within a file and of
    the other files is kept (a stable sort)."""
    rank = {f"{TESTS.name}/{name}": i for i, name in enumerate(LONG_FILES)}
    items.sort(key=lambda item: rank.get(item.nodeid.split("::")[0], len(rank)))


# ----------------------------------------------------------------------------- randomness
@pytest.fixture
def rng():
    """A seeded random generator (fresh for every test, so tests are order independent)."""
    return np.random.default_rng(SEED)


# ----------------------------------------------------------------------------- builders
def make_icosphere(subdivisions=2, radius=1.0):
    ico = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    return DataMesh(np.asarray(ico.vertices), np.asarray(ico.faces), name="icosphere")


def make_cube():
    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    return DataMesh(np.asarray(box.vertices), np.asarray(box.faces), name="cube")


def make_circle(n=64, radius=1.0):
    a = 2.0 * np.pi * np.arange(n) / n
    V = np.stack([radius * np.cos(a), radius * np.sin(a), 0.1 * np.sin(3 * a)], axis=1)
    E = np.stack([np.arange(n), (np.arange(n) + 1) % n], axis=1)
    return DataMesh(V, E, name="circle")


def make_point_cloud(n=400, seed=SEED):
    return DataMesh(np.random.default_rng(seed).random((n, 3)), name="point_cloud")


def make_mixed(seed=SEED):
    """Icosphere triangles + spikes and a loose polyline (edges) + free points, one V."""
    r = np.random.default_rng(seed)
    ico = trimesh.creation.icosphere(subdivisions=1)
    Vs = np.asarray(ico.vertices)
    F = np.asarray(ico.faces)
    n = Vs.shape[0]
    tips = Vs[:8] * 1.6                                   # spikes from 8 sphere vertices
    line = np.stack([np.linspace(-1, 1, 7), np.full(7, 2.0), 0.3 * np.linspace(-1, 1, 7) ** 2],
                    axis=1)                               # a separate open polyline
    free = r.normal(size=(12, 3)) * 0.3 + np.array([0.0, 0.0, 2.5])
    V = np.concatenate([Vs, tips, line, free])
    E = [(i, n + i) for i in range(8)]
    E += [(n + 8 + i, n + 9 + i) for i in range(6)]
    E += [(0, n + 8)]                                     # join the polyline to the sphere
    P = list(range(n + 15, n + 27)) + [10, 11, 12]        # free points and 3 sphere vertices
    return DataMesh(V, points=P, edges=np.array(E), triangles=F, name="mixed")


def make_nonmanifold():
    """Triangles where A w~ < 1 somewhere without the clamp: a 4-page book on one edge
    (edge valence 4), isolated triangles (v = 1), and a bow-tie (two triangles sharing only
    a vertex, (v, e) = (2, 1))."""
    V = [[0, 0, 0], [0, 0, 1]]                            # the book's spine
    T = []
    for k in range(4):
        a = 2 * np.pi * k / 4 + 0.3
        V.append([np.cos(a), np.sin(a), 0.5])
        T.append((0, 1, len(V) - 1))
    # isolated triangles
    for off in ([3.0, 0, 0], [3.0, 2.0, 0.5], [0, 3.0, 1.0]):
        o = np.array(off)
        V += [list(o), list(o + [1, 0, 0]), list(o + [0.2, 0.9, 0.3])]
        T.append((len(V) - 3, len(V) - 2, len(V) - 1))
    # bow-tie
    c = np.array([-2.0, -2.0, 0.0])
    V += [list(c), list(c + [1, 0.3, 0]), list(c + [0.8, 1, 0.2]), list(c + [-1, -0.2, 0.1]),
          list(c + [-0.7, -1, -0.2])]
    k = len(V) - 5
    T += [(k, k + 1, k + 2), (k, k + 3, k + 4)]
    return DataMesh(np.array(V, dtype=float), np.array(T), name="nonmanifold")


def make_segment_star(seed=SEED):
    """A star of 5 segments (centre valence 5, tips valence 1) plus a chain: unequal end
    valences, where the edge weight's maximum exceeds A."""
    r = np.random.default_rng(seed)
    tips = r.normal(size=(5, 3))
    chain = np.cumsum(r.normal(size=(6, 3)) * 0.4, axis=0) + np.array([3.0, 0, 0])
    V = np.concatenate([[[0.0, 0.0, 0.0]], tips, chain])
    E = [(0, 1 + i) for i in range(5)] + [(6 + i, 7 + i) for i in range(5)] + [(1, 6)]
    return DataMesh(V, np.array(E), name="segment_star")


BUILDERS = {
    "point_cloud": make_point_cloud,
    "circle": make_circle,
    "segment_star": make_segment_star,
    "icosphere": make_icosphere,
    "cube": make_cube,
    "mixed_mesh": make_mixed,
    "nonmanifold_mesh": make_nonmanifold,
}


# ----------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="session")
def zoo():
    """Every procedural mesh, by name (see ``ZOO_NAMES``)."""
    return {name: BUILDERS[name]() for name in ZOO_NAMES}


@pytest.fixture(scope="session")
def icosphere(zoo):
    return zoo["icosphere"]


@pytest.fixture(scope="session")
def cube(zoo):
    return zoo["cube"]


@pytest.fixture(scope="session")
def circle(zoo):
    return zoo["circle"]


@pytest.fixture(scope="session")
def point_cloud(zoo):
    return zoo["point_cloud"]


@pytest.fixture(scope="session")
def mixed_mesh(zoo):
    return zoo["mixed_mesh"]


@pytest.fixture(scope="session")
def nonmanifold_mesh(zoo):
    return zoo["nonmanifold_mesh"]


@pytest.fixture(scope="session")
def segment_star(zoo):
    return zoo["segment_star"]


@pytest.fixture(scope="session")
def octopus():
    """``tests/data/octopus_low.obj``: 451 V, 898 triangles, closed manifold."""
    return DataMesh.load(DATA / "octopus_low.obj")


@pytest.fixture(scope="session")
def trefoil():
    """``tests/data/trefoil.obj``: closed polyline, 287 V, 287 edges."""
    return DataMesh.load(DATA / "trefoil.obj")


@pytest.fixture(scope="session")
def shared_data():
    """Path of the project's shared data folder (``<repo>/../shared/data``); skips if absent."""
    path = SHARED_DATA
    if not (path / "README.md").is_file():
        pytest.skip(f"shared data folder not found at {path}: the tests on the bunny, "
                    "Thingi10K meshes and curves need it (CI has it)")
    return path


@pytest.fixture(scope="session")
def bunny(shared_data):
    """The paper's Stanford bunny (3,485 V, 6,966 triangles) from the shared data."""
    return DataMesh.load(shared_data / "bunny.off")
