"""The public data's registry (tracer.datasets): checksums against the project's own copies,
downloads from a local server laid out as raw.githubusercontent.com, the STL conversion
against trimesh's reading, and the errors a user without data or network gets."""

import hashlib
import http.server
import struct
import threading

import numpy as np
import pytest
import trimesh

from tracer import datasets
from tracer.cli import main

#: a tetrahedron's four triangles (outward), as float32 corners
TETRA = np.array([[[0, 0, 0], [0, 1, 0], [1, 0, 0]], [[0, 0, 0], [1, 0, 0], [0, 0, 1]],
                  [[0, 0, 0], [0, 0, 1], [0, 1, 0]], [[1, 0, 0], [0, 1, 0], [0, 0, 1]]],
                 np.float32) * np.float32(0.1)


def binary_stl(tris):
    out = b"binary stl".ljust(80) + struct.pack("<I", len(tris))
    for t in tris:
        out += struct.pack("<3f", 0, 0, 0) + t.astype("<f4").tobytes() + b"\0\0"
    return out


def ascii_stl(tris):
    lines = ["solid t"]
    for t in tris:
        lines += ["facet normal 0 0 0", "outer loop"]
        lines += [f"vertex {x:.9e} {y:.9e} {z:.9e}" for x, y, z in t]
        lines += ["endloop", "endfacet"]
    return ("\n".join(lines + ["endsolid t"]) + "\n").encode()


@pytest.fixture
def isolated(tmp_path, monkeypatch):
    """No local copies, an empty cache in tmp_path, downloads allowed."""
    monkeypatch.delenv(datasets.ENV_LOCAL, raising=False)
    monkeypatch.delenv(datasets.ENV_OFFLINE, raising=False)
    monkeypatch.delenv(datasets.ENV_URL, raising=False)
    monkeypatch.setenv(datasets.ENV_CACHE, str(tmp_path / "cache"))
    monkeypatch.setattr(datasets, "SHIPPED", tmp_path / "no-checkout")
    return tmp_path / "cache"


@pytest.fixture
def server(tmp_path):
    """A local HTTP server of tmp_path/www (``{base}/{repo}/{commit}/{path}``); its base URL."""
    root = tmp_path / "www"
    root.mkdir()

    class Quiet(http.server.SimpleHTTPRequestHandler):
        def __init__(self, *a, **k):
            super().__init__(*a, directory=str(root), **k)

        def log_message(self, *a):
            pass

    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Quiet)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    yield root, f"http://127.0.0.1:{httpd.server_address[1]}"
    httpd.shutdown()


def publish(root, entry, data):
    p = root / entry.source.repo / entry.source.commit / entry.path
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_bytes(data)


def sha(data):
    return hashlib.sha256(data).hexdigest()


def test_every_registered_file_matches_the_projects_copy(shared_data, monkeypatch):
    """Each entry's SHA-256 and size against the data folder's copy (read, not trusted)."""
    monkeypatch.setenv(datasets.ENV_LOCAL, str(shared_data))
    for name, e in datasets.REGISTRY.items():
        p = shared_data / name
        assert p.stat().st_size == e.size, name
        assert sha(p.read_bytes()) == e.sha256, name
        assert datasets.find(name) is not None


def test_stl_conversion_reads_as_trimesh_does():
    """Binary and ASCII STL give the same OBJ; its triangles are the STL's, read by trimesh."""
    a, b = datasets.stl_to_obj(binary_stl(TETRA)), datasets.stl_to_obj(ascii_stl(TETRA))
    assert a == b
    obj = trimesh.load(trimesh.util.wrap_as_stream(a), file_type="obj", process=False)
    assert len(obj.vertices) == 4  # 12 corners, 4 distinct
    np.testing.assert_array_equal(np.asarray(obj.vertices)[obj.faces].astype(np.float32), TETRA)
    ref = trimesh.load(trimesh.util.wrap_as_stream(binary_stl(TETRA)), file_type="stl")
    assert np.isclose(ref.volume, obj.volume) and obj.volume > 0  # orientation kept


def entries(tmp_path):
    stl = binary_stl(TETRA)
    obj = datasets.stl_to_obj(stl, ("# a tetrahedron",))
    src = datasets.Source("someone/data", "0" * 40, "CC0")
    conv = datasets.Entry("test/tetra.obj", sha(obj), len(obj), src, "models/tetra.stl",
                          "a tetrahedron", "CC0", "stl", sha(stl), ("# a tetrahedron",))
    text = b"v 0 0 0\n"
    copy = datasets.Entry("test/point.obj", sha(text), len(text), src, "point.obj", "a point",
                          "CC0")
    return (conv, stl, obj), (copy, text)


def test_download_checks_converts_and_caches(isolated, server, monkeypatch, tmp_path):
    root, base = server
    (conv, stl, obj), (copy, text) = entries(tmp_path)
    monkeypatch.setattr(datasets, "REGISTRY", {e.name: e for e in (conv, copy)})
    publish(root, conv, stl)
    publish(root, copy, text)
    lines = []
    p = datasets.path(conv.name, base=base, progress=lines.append)
    assert p == isolated / conv.name and p.read_bytes() == obj
    assert lines and base in lines[0]
    monkeypatch.setenv(datasets.ENV_URL, base + "/")  # a mirror named by the environment
    assert datasets.path(copy.name).read_bytes() == text
    # cached: found again with the server's copy gone and downloads off
    (root / copy.source.repo).rename(root / "gone")
    monkeypatch.setenv(datasets.ENV_OFFLINE, "1")
    assert datasets.path(conv.name) == p
    assert datasets.status(conv.name) == ("cached", p)
    # a cached file changed afterwards is refused, not used
    p.write_bytes(obj + b"# edited\n")
    with pytest.raises(datasets.DataUnavailable, match="SHA-256"):
        datasets.path(conv.name)


def test_a_changed_source_is_refused_and_nothing_kept(isolated, server, monkeypatch, tmp_path):
    root, base = server
    (conv, stl, _), _ = entries(tmp_path)
    monkeypatch.setattr(datasets, "REGISTRY", {conv.name: conv})
    publish(root, conv, stl[:-1] + b"\1")  # one byte off
    with pytest.raises(datasets.DataUnavailable, match="not the registered"):
        datasets.path(conv.name, base=base)
    assert not isolated.exists() or not any(isolated.rglob("*"))


def test_missing_data_says_how_to_get_it(isolated, monkeypatch, tmp_path):
    (conv, _, _), _ = entries(tmp_path)
    monkeypatch.setattr(datasets, "REGISTRY", {conv.name: conv})
    monkeypatch.setenv(datasets.ENV_OFFLINE, "1")
    with pytest.raises(datasets.DataUnavailable, match="tracer data fetch test/tetra.obj"):
        datasets.path(conv.name)
    monkeypatch.delenv(datasets.ENV_OFFLINE)
    with pytest.raises(FileNotFoundError, match="cannot download"):  # no server there
        datasets.path(conv.name, base="http://127.0.0.1:9")


def test_local_copies_come_first_and_are_checked(isolated, monkeypatch, tmp_path):
    (conv, _, obj), _ = entries(tmp_path)
    monkeypatch.setattr(datasets, "REGISTRY", {conv.name: conv})
    local = tmp_path / "copies"
    (local / "test").mkdir(parents=True)
    (local / conv.name).write_bytes(obj)
    monkeypatch.setenv(datasets.ENV_LOCAL, str(local))
    assert datasets.path(conv.name, download=False) == local / conv.name
    assert datasets.status(conv.name)[0] == "local"
    (local / conv.name).write_bytes(obj[:-2])
    with pytest.raises(datasets.DataUnavailable, match="changed or partial"):
        datasets.find(conv.name)


def test_the_data_command(isolated, capsys, monkeypatch):
    monkeypatch.setenv(datasets.ENV_OFFLINE, "1")
    assert main(["data", "list", "thingi10k"]) == 0
    out = capsys.readouterr().out
    assert out.count("missing") == len(datasets.GROUPS["thingi10k"])
    assert main(["data", "fetch", "no-such-file"]) == 2
    assert main(["data", "fetch", "curves/k5_graph.obj"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and all(e.startswith("error: ") for e in err)
    assert "tracer data fetch curves/k5_graph.obj" in err[1]


def test_a_reproduction_without_its_data_says_so(isolated, monkeypatch, tmp_path):
    """The grid experiment asked for Thingi10K that it cannot get: it measures nothing and its
    claims say "not run" and why, instead of judging a smaller mesh set."""
    from tracer.reproduce import claims, experiments

    monkeypatch.setenv(datasets.ENV_OFFLINE, "1")
    s = dict(experiments.SETTINGS["smoke"]["grid"], thingi10k=True)
    res = experiments.grid(tmp_path / "grid", s, {"scheduler": "serial", "workers": None})
    assert res["missing_data"] == ["thingi10k"]
    assert not (tmp_path / "grid").exists()
    rows = [r for r in claims.evaluate({"grid": res}) if r["experiment"] == "grid"]
    assert rows and all(r["verdict"] == claims.NOT_RUN for r in rows)
    assert all("thingi10k" in r["reason"] and "tracer data fetch" in r["reason"] for r in rows)
    assert all("Thingi10K" in r["data"] for r in rows)


def test_tracer_reproduce_without_its_data_writes_a_page_that_says_so(isolated, monkeypatch,
                                                                      tmp_path):
    """The command end to end, offline, with the grid asking for Thingi10K: exit 0, a page
    and claims whose grid rows say "not run" and name the data."""
    import json

    from tracer.reproduce import experiments

    monkeypatch.setenv(datasets.ENV_OFFLINE, "1")
    monkeypatch.setitem(experiments.SETTINGS["smoke"], "grid",
                        dict(experiments.SETTINGS["smoke"]["grid"], thingi10k=True))
    out = tmp_path / "res"
    assert main(["reproduce", "--smoke", "--only", "grid", "--out", str(out), "-q",
                 "--allow-dirty"]) == 0
    rows = [r for r in json.loads((out / "claims.json").read_text())
            if r["experiment"] == "grid"]
    assert rows and all(r["verdict"] == "not run" and "thingi10k" in r["reason"] for r in rows)
    page = (out / "reproduction.md").read_text(encoding="utf-8")
    assert "needs data this run could not get: thingi10k" in page
