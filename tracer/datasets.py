"""The public data the benchmarks, studies and reproduction read, got on first use and checked.

Every file is named by its path in the registry (``thingi10k/72960_guardian_lion.obj``), with
its SHA-256, its public source (a GitHub repository at a fixed commit) and how it was made from
that source: a byte copy, or an STL turned into an OBJ (vertices with bit-identical float32
coordinates merged, in order of first use, written with 9 significant digits; this reproduces
the registered bytes exactly, so the same checksum guards both).

Where a file is looked for, in order (:func:`path`):

1. ``$SMOOTHDIST_DATA``: a folder of local copies, laid out as the registry names them (our CI
   names its copy of the data here); a file there with another checksum is an error;
2. ``scenes/data`` of a repository checkout (the small files the repository ships);
3. the user cache: ``$SMOOTHDIST_DATA_CACHE``, else the platform's cache folder
   (``~/.cache/smoothdist/data`` on Linux);
4. a download from the source into that cache (checked, then renamed into place, so that an
   interrupted download never leaves a file that looks complete), from
   ``raw.githubusercontent.com`` or ``$SMOOTHDIST_DATA_URL`` (a mirror laid out the same way).
   ``SMOOTHDIST_OFFLINE=1`` stops before this step.

A file that cannot be had raises :class:`DataUnavailable` with the command that gets it
(``tracer data fetch NAME``).
"""

import hashlib
import os
import urllib.request
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tracer.errors import TracerError
from tracer.outputs import write_bytes

#: a folder of local copies (checked like downloads)
ENV_LOCAL = "SMOOTHDIST_DATA"
#: moves the download cache
ENV_CACHE = "SMOOTHDIST_DATA_CACHE"
#: ``1``: never download
ENV_OFFLINE = "SMOOTHDIST_OFFLINE"
#: where the sources are downloaded from: ``{base}/{repo}/{commit}/{path}``
RAW = "https://raw.githubusercontent.com"
#: another base URL laid out as :data:`RAW` (a mirror, a proxy); read at each download
ENV_URL = "SMOOTHDIST_DATA_URL"
#: the repository's own small copies (present in a checkout, not in an installed package)
SHIPPED = Path(__file__).resolve().parents[1] / "scenes" / "data"


class DataUnavailable(TracerError, FileNotFoundError):
    """A registered file is in no local folder and cannot be downloaded (offline, no network,
    or the source changed); also a :class:`FileNotFoundError`, and reported by the command line
    as one ``error: ...`` line."""


@dataclass(frozen=True)
class Source:
    """A public repository at a fixed commit."""

    repo: str
    commit: str
    licence: str


LIBIGL = Source("libigl/libigl-tutorial-data", "c1f9ede366d02e3531ecbaec5e3769312f31cccd",
                "no licence file; README: Stanford 3D Scanning Repository")
MESHPREP = Source("DragonAceNL/MeshPrep", "bcd73f56074584f02b35b2a5b47aa4285785ed4f",
                  "Thingi10K metadata per model (below)")
DSS = Source("cscvlab/Dual-Spherical-Shell", "23b030b22f0074bdd8bb81cc0652a161de8a2dde",
             "Thingi10K metadata per model (below)")
FRMA = Source("gcherchi/FastAndRobustMeshArrangements",
              "bf7eb71da991a61ff5414946a4b2754bbd327e41", "Thingi10K metadata per model (below)")
TRIMESH = Source("mikedh/trimesh", "a513c0e2cfa6dfbd3121a6dfd8ceb002b9ef55d8", "MIT")
CURVES = Source("chrisyu-cs/repulsive-curves", "78a0c15da6edfc19a3f6607aebc59d769b1e59da", "MIT")

#: the comment line every converted Thingi10K OBJ carries second
STL_NOTE = ("# Converted from STL; only bit-identical vertices merged; face order and "
            "orientation unchanged.")


@dataclass(frozen=True)
class Entry:
    """One registered file: its checksum and size, where it comes from, how it was made, what
    it is and its licence. ``header``: the comment lines a converted OBJ starts with."""

    name: str
    sha256: str
    size: int
    source: Source
    path: str
    what: str
    licence: str
    convert: str = "copy"
    source_sha256: str = ""
    header: tuple = ()

    def url(self, base=RAW):
        return f"{base}/{self.source.repo}/{self.source.commit}/{self.path}"


def _thingi(slug, thing, title, author, licence, sha, size, src, path, src_sha=""):
    """A Thingi10K model's entry, ``thingi10k/<slug>.obj`` (``<file id>_<name>``); an STL
    source is converted, an OBJ one copied."""
    fid = slug.split("_")[0]
    name = f"thingi10k/{slug}.obj"
    header = ()
    if path.lower().endswith(".stl"):
        header = (f"# Thingi10K file {fid} (Thingiverse thing {thing}): {title} by {author}. "
                  f"License: {licence}.", STL_NOTE)
    return Entry(name, sha, size, src, path, f"Thingi10K {fid}, {title} by {author} "
                 f"(https://www.thingiverse.com/thing:{thing})", licence,
                 "stl" if header else "copy", src_sha, header)


_MP = "tests/fixtures/thingi10k/"
#: every registered file, by name
REGISTRY = {e.name: e for e in [
    Entry("bunny.off", "dda85ca6dc03ed83a0b754611d5c0b1a3c8ba5234e690479ac4a04063e6a7d4d",
          226247, LIBIGL, "bunny.off", "the paper's Stanford bunny, 3,485 V, 6,966 triangles",
          LIBIGL.licence),
    Entry("textures/jade_matcap.png",
          "9cc2da186246cc26a1f3b0a6bf4b78f3a1428905a90a19af55bd86417531c1d8", 80369, LIBIGL,
          "jade.png", "512x512 jade matcap", "public domain (commit message)"),
    Entry("meshes/torus.obj", "2f62538cd1c779be6a507b92298836b615f2d129fd91a037668bf47145b1314b",
          310779, TRIMESH, "models/torus.STL", "closed torus, 8,700 triangles", "MIT", "stl",
          "91441a7f60479bda93c59dd88134da3b4f33d1df71729fe71e1b2ae989974da3",
          ("# torus from mikedh/trimesh models/torus.STL (MIT License).",
           "# Converted from binary STL; only bit-identical vertices merged; face order and "
           "orientation unchanged.")),
    Entry("meshes/double_torus.obj",
          "68de4347f4ab1df1972c1b22cd49824e824b42b7758481ef0f3c17928a043a33", 498598, CURVES,
          "scenes/DoubleTorus/DoubleTorus.obj", "closed genus-2 surface, 10,500 triangles", "MIT"),
    Entry("curves/trefoil.obj", "f0d8ac201c7d5269a558c5d043b1109629db5172a86e2b82df8a9f9d54005ccd",
          11491, CURVES, "scenes/BunnyCurvePacking/nice_trefoil.obj", "trefoil knot, 287 edges",
          "MIT"),
    Entry("curves/capillary_networks.obj",
          "86da30f09c6d0f36eadc83a1fe92a6a87cab3dc5025803954ce027a64d3ba771", 88934, CURVES,
          "scenes/CapillaryNetwork/two-networks.obj", "two branching networks, 2,150 edges",
          "MIT"),
    Entry("curves/k5_graph.obj", "29f9fe80fb9896b1fafaffe00bd7f8524b63af40374dc0877fea7335c56bb55d",
          25609, CURVES, "scenes/GraphDrawing/k5.obj", "complete graph K5, 640 edges", "MIT"),
    Entry("curves/freedman_unknot.obj",
          "576aef1dd41f15c9d611bfd0181df0d86806a2cf14878075496aaa9df09682a6", 48529, CURVES,
          "scenes/FreedmanUnknot/freedmancurve1200.obj", "Freedman's unknot, 1,184 edges",
          "MIT"),
    _thingi("37825_minecraft_creeper", 11825, "Minecraft Creeper", "kyle170", "CC BY-SA",
            "91af8c612d87aee88c5d0084b34a9318a8ff63a618f7464240e3023803555931", 4886, MESHPREP,
            _MP + "non_manifold/37825.stl",
            "44b6e7cad8faf6657e52b57cc5cd8371dc73b3d049467bbd40cc8c724648e2bd"),
    _thingi("97171_punch_card_reader", 33696, "3-bit Mechanical Punch Card Reader", "chris",
            "CC0 (Public Domain Dedication)",
            "1577dc862992b638774ac622ea617000cdc546506eb87cc9b620647e120bc644", 6264, MESHPREP,
            _MP + "many_small_holes/97171.stl",
            "d4309fa2137d2aef169e4f3fd049019bde5e489bb80b00c4c19443d6f2745467"),
    _thingi("122126_wedding_vase", 44305, "Wedding Vase", "ecafruoy", "CC BY-SA",
            "5c72be35e04fbbb28518b7365d9f96e0c9d8c9d376649c4997cc6de308b24a70", 10971, MESHPREP,
            _MP + "many_small_holes/122126.stl",
            "28a47255a5c01faf57c9f2ba8e17c0a0190d94861c790a65d0b554514cabc171"),
    _thingi("65778_cube_libre_puzzle", 21042, "Cube Libre puzzle", "richgain", "CC BY",
            "bb5cb013436c8c8339dc696cda92610af6f53bb53806980dcdf1f6eb5e4f7b93", 9471, MESHPREP,
            _MP + "fragmented/65778.stl",
            "4485dadc9a22ddfb34174c76173c135bc88835386becf8fc75bc17c956c90f7e"),
    _thingi("1004825_dread_gazebo", 624569, "The Dread Gazebo", "mz4250", "CC BY-SA",
            "5ed523222a13fc5f854204f0353f16c7a98950179efdc3327fb1e12930295484", 19915, MESHPREP,
            _MP + "fragmented/1004825.stl",
            "5edba78c616f5b7fecb618b05bd8aa5fbfa2706d59a867d5512d470b39529ddf"),
    _thingi("53750_hilbert_cube", 16343, "Hilbert Cube", "tbuser", "CC BY-SA",
            "b269245bac87c40fa061b303d8ef665d595a564d5d1b309a086f0ab0dbc17485", 138115, DSS,
            "submodules/geolab-copy/data/53750.stl",
            "8de1fb671272f89213b9b82995c6667625f70090ac51880118f892916538bc25"),
    _thingi("40509_brain_slug_hair_clip", 12537, "Brain Slug Hair Clip", "CarryTheWhat", "CC BY",
            "bd62b6053ac03792fc3cfe5a09edae0581f85c6f427c2468b59c0fd3ea00396b", 496717, FRMA,
            "data/40509.stl",
            "8b812e8f475d200136632a2f394638aa116f905b242338ab19d1fe93bb5ebf56"),
    _thingi("76277_gomphotherium_foot", 25374, "Gomphotherium Foot", "PrettySmallThings", "CC BY",
            "5a323e9bf6fa3b51188d08fc429adfbb0f3a3e3fbb235f872cda900480573306", 1444543, DSS,
            "thingi32_obj/76277.obj"),
    _thingi("58168_ahabs_last_stand", 17887, "Ahab's Last Stand", "BrianStamile", "CC BY",
            "d5bbd18748572a903dafedd04192622005c832b6db0e339ac45ef33fdd6428dd", 1775560, DSS,
            "submodules/geolab-copy/data/58168.obj"),
    _thingi("64764_thinking_gargoyle", 20634, "Thinking Gargoyle", "cbabbage", "CC BY",
            "f7f3f43e2a9278279108fbe69923edd429dde827b63c7b015047201e93d1a3fb", 2797089, DSS,
            "thingi32_obj/64764.obj"),
    _thingi("72960_guardian_lion", 24047, "Guardian Lion; Northern Qi dynasty", "met", "CC BY-SA",
            "4d56d7b44aab154baa6da4805be29adbd1ca5b5037f58283f40f81d939ff7ddb", 3459736, DSS,
            "thingi32_obj/72960.obj"),
    _thingi("79241_torso_of_an_emperor", 26536, "Torso of an Emperor; Roman Imperial",
            "AminimalStudio", "CC BY",
            "8a54c99ffa9a6d8b98ae1d76228f35860f09140bc37e762536f6aabae81ad725", 3667457, DSS,
            "thingi32_obj/79241.obj"),
]}

#: named sets of files (``tracer data fetch thingi10k``)
GROUPS = {"thingi10k": sorted(n for n in REGISTRY if n.startswith("thingi10k/")),
          "curves": sorted(n for n in REGISTRY if n.startswith("curves/")),
          "meshes": sorted(n for n in REGISTRY if n.startswith("meshes/"))}


# ============================================================================ where
def cache_dir():
    """The download cache: ``$SMOOTHDIST_DATA_CACHE``, else the platform's user cache folder
    plus ``smoothdist/data``."""
    value = os.environ.get(ENV_CACHE, "").strip()
    if value:
        return Path(value).expanduser().resolve()
    try:
        from numba.misc.appdirs import AppDirs  # numba internals, absent in some versions

        base = AppDirs(appname="smoothdist", appauthor=False).user_cache_dir
    except Exception:  # pragma: no cover - numba without appdirs
        base = os.path.join(os.path.expanduser("~"), ".cache", "smoothdist")
    return Path(base) / "data"


def local_dirs():
    """The folders searched before the cache: ``$SMOOTHDIST_DATA`` (when set), then the
    repository's ``scenes/data`` (in a checkout)."""
    out = []
    value = os.environ.get(ENV_LOCAL, "").strip()
    if value:
        out.append(Path(value).expanduser().resolve())
    if SHIPPED.is_dir():
        out.append(SHIPPED)
    return out


def offline():
    return os.environ.get(ENV_OFFLINE, "").strip().lower() in ("1", "true", "yes", "on")


def sha256_of(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def entry(name):
    """The registry's entry for ``name`` (a :class:`DataUnavailable` naming the known ones
    when there is none)."""
    try:
        return REGISTRY[name]
    except KeyError:
        raise DataUnavailable(f"no registered data file {name!r}; known: "
                              f"{', '.join(sorted(REGISTRY))}") from None


def find(name):
    """The local path of ``name`` without downloading (checked), or None."""
    e = entry(name)
    for folder in [*local_dirs(), cache_dir()]:
        p = folder / name
        if p.is_file():
            digest = sha256_of(p)
            if digest != e.sha256:
                raise DataUnavailable(f"{p}: SHA-256 {digest[:16]}... is not the registered "
                                      f"{e.sha256[:16]}... (a changed or partial copy: "
                                      "remove it, or point $SMOOTHDIST_DATA elsewhere)")
            return p
    return None


def base_url():
    """``$SMOOTHDIST_DATA_URL`` when set, else :data:`RAW`."""
    return os.environ.get(ENV_URL, "").strip().rstrip("/") or RAW


def path(name, download=True, base=None, progress=None):
    """The local path of the registered file ``name``: found in a local folder or the cache,
    else downloaded (``download`` and not ``$SMOOTHDIST_OFFLINE``) from ``base`` (default
    :func:`base_url`) into the cache. ``progress``: a callable given one line per download."""
    found = find(name)
    if found is not None:
        return found
    if not download or offline():
        raise DataUnavailable(f"{name} is not here (looked in {_where()}); get it with "
                              f"`tracer data fetch {name}` (downloads {entry(name).size:,} "
                              f"bytes), or set ${ENV_LOCAL} to a folder of copies")
    return _download(entry(name), base or base_url(), progress)


def group_folder(group, download=True, base=None, progress=None):
    """The folder that holds every file of ``group`` (:data:`GROUPS`); the files are fetched
    first where missing. The folder may hold other files too."""
    names = GROUPS[group]
    paths = [path(n, download, base, progress) for n in names]
    parents = {p.parent for p in paths}
    if len(parents) == 1:
        return parents.pop()
    # copies spread over several folders (some local, some cached): gather them in the cache
    dest = cache_dir() / group
    for n, p in zip(names, paths):
        target = cache_dir() / n
        if p != target:
            target.parent.mkdir(parents=True, exist_ok=True)
            _place(p.read_bytes(), target, REGISTRY[n])
    return dest


def status(name):
    """``(where, path)``: ``"local"``, ``"shipped"``, ``"cached"``, ``"missing"`` or
    ``"changed"`` (a copy whose checksum is not the registered one; path None)."""
    try:
        p = find(name)
    except DataUnavailable:
        return "changed", None
    if p is None:
        return "missing", None
    if p.is_relative_to(SHIPPED):
        return "shipped", p
    return ("cached" if p.is_relative_to(cache_dir()) else "local"), p


def _where():
    return ", ".join(str(p) for p in [*local_dirs(), cache_dir()])


# ============================================================================ download
def _download(e, base, progress):
    url = e.url(base)
    if progress:
        progress(f"downloading {e.name} ({e.size:,} bytes) from {url}")
    try:
        with urllib.request.urlopen(url, timeout=60) as r:
            data = r.read()
    except (OSError, ValueError) as exc:
        raise DataUnavailable(f"{e.name}: cannot download {url} ({exc}); with no network, "
                              f"set ${ENV_LOCAL} to a folder of copies") from None
    want = e.source_sha256 or e.sha256
    got = hashlib.sha256(data).hexdigest()
    if got != want:
        raise DataUnavailable(f"{e.name}: the download from {url} has SHA-256 {got[:16]}..., "
                              f"not the registered {want[:16]}...; nothing was kept")
    if e.convert == "stl":
        data = stl_to_obj(data, e.header)
    target = cache_dir() / e.name
    _place(data, target, e)
    return target


def _place(data, target, e):
    """Write ``data`` to ``target`` through a temporary file in its folder, after checking it
    against the entry's SHA-256."""
    got = hashlib.sha256(data).hexdigest()
    if got != e.sha256:
        raise DataUnavailable(f"{e.name}: made from its source, SHA-256 {got[:16]}... is not "
                              f"the registered {e.sha256[:16]}...; nothing was kept")
    target.parent.mkdir(parents=True, exist_ok=True)
    write_bytes(target, data)


# ============================================================================ conversion
def stl_triangles(data):
    """The corners of an STL file's triangles, ``(m, 3, 3)`` float32, binary or ASCII (a binary
    file is one whose size is 84 + 50 x its triangle count)."""
    if len(data) >= 84:
        m = int(np.frombuffer(data[80:84], "<u4")[0])
        if len(data) == 84 + 50 * m:
            rec = np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attr", "<u2")])
            return np.frombuffer(data, rec, count=m, offset=84)["corners"]
    words = [line.split()[1:4] for line in data.decode("ascii").splitlines()
             if line.strip().startswith("vertex")]
    return np.array(words, dtype=np.float32).reshape(-1, 3, 3)


def stl_to_obj(data, header=()):
    """An STL file's bytes as OBJ bytes: vertices with bit-identical float32 coordinates merged
    (numbered in order of first use), ``%.9g`` coordinates, faces in the file's order and
    orientation, the ``header`` comment lines first."""
    corners = np.ascontiguousarray(stl_triangles(data).reshape(-1, 3))
    keys = corners.view(np.dtype((np.void, 12))).ravel()
    _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    lines = list(header)
    lines += ["v " + " ".join("%.9g" % float(x) for x in row) for row in corners[first[order]]]
    lines += ["f %d %d %d" % tuple(f) for f in rank[inverse.ravel()].reshape(-1, 3) + 1]
    return ("\n".join(lines) + "\n").encode("ascii")
