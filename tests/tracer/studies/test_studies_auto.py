"""The studies on a mesh of the user's own (issue 46, item 5): ``ablate-beta`` and
``ablate-alpha`` render it with its own automatic parameters and a camera framing it, not the
paper's (alpha 200 left 4 of 16,384 pixels of a noisy icosphere's points hit, shown as
"err 0.00 %"), and every output names the parameters and where they came from.

A noisy icosphere (162 vertices) written as OBJ, rendered at 24 x 24 px; the auto parameters
are computed here independently with ``SmoothDistanceField``.
"""

import csv
import json
import math

import numpy as np
import pytest

from smoothdist import DataMesh, SmoothDistanceField
from tracer.cli import main
from tracer.studies import alpha as alpha_study
from tracer.studies import beta as beta_study

SIZE = 24
#: a panel's hit set counts as non-trivial above this share of the image
NON_TRIVIAL = 0.05


@pytest.fixture(scope="module")
def noisy_ico(tmp_path_factory):
    trimesh = pytest.importorskip("trimesh")
    mesh = trimesh.creation.icosphere(subdivisions=2)
    rng = np.random.default_rng(0)
    mesh.vertices = mesh.vertices + 0.02 * rng.standard_normal(mesh.vertices.shape)
    path = tmp_path_factory.mktemp("ico") / "noisy_ico.obj"
    mesh.export(path)
    return path


def _auto(path, kind):
    return SmoothDistanceField(DataMesh.load(path).as_kind(kind))


def _rows(path):
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def test_beta_on_a_users_mesh_uses_its_auto_parameters(noisy_ico, tmp_path, capsys):
    """No --alpha: each type at the mesh's auto_surface() (alpha, alpha_U, offset), framed
    from the front; every beta = 0 render hits more than 5 % of the image and every error is
    defined; the printed lines, the CSV, the JSON and the report name the parameters."""
    out = tmp_path / "auto"
    assert main(["ablate-beta", str(noisy_ico), "-o", str(out), "--size", str(SIZE),
                 "--betas", "0,1", "--grid-betas", "0,1", "--scheduler", "serial"]) == 0
    printed = capsys.readouterr().out
    rows = _rows(out / beta_study.BETA_CSV)
    assert {r["type"] for r in rows} == {"points", "edges", "triangles"}
    for kind in ("points", "edges", "triangles"):
        a, u, off = _auto(noisy_ico, kind).auto_surface()
        mine = [r for r in rows if r["type"] == kind]
        assert len(mine) == 2
        for r in mine:
            assert math.isclose(float(r["alpha"]), a, rel_tol=1e-6), (kind, r["alpha"], a)
            assert math.isclose(float(r["alpha_u"]), u, rel_tol=1e-6)
            assert math.isclose(float(r["offset"]), off, rel_tol=1e-6, abs_tol=1e-12)
            assert r["parameters"] == "auto"
            assert math.isfinite(float(r["error_rel_diag"])), r   # never "undefined" here
        ref = next(r for r in mine if float(r["beta"]) == 0.0)
        assert float(ref["hit_fraction"]) > NON_TRIVIAL, (kind, ref["hit_fraction"])
        assert f"{kind} alpha {a:.4g}, alpha_U {u:.4g}" in printed
    assert printed.startswith("parameters: the mesh's auto parameters")
    summary = next(ln for ln in printed.splitlines() if ln.startswith("Beta ablation of"))
    assert "at the mesh's auto parameters" in summary and "warning" not in printed
    params = json.loads((out / beta_study.BETA_PARAMS).read_text())
    assert params["paper_parameters"] is False and params["view"] == "front"
    assert params["authors_reference"] is False
    assert params["parameters"].startswith("the mesh's auto parameters")
    assert "the mesh's auto parameters" in (out / "report.md").read_text(encoding="utf-8")


def test_beta_paper_parameters_on_a_users_mesh_say_so(noisy_ico, tmp_path, capsys):
    """--paper-parameters: alpha 200, alpha_U 1200 and the authors' camera on any mesh, said
    in every output; the points of the icosphere are then (almost) not hit, their error is
    undefined (empty in the CSV, "undefined" in the plots) and a warning says why."""
    out = tmp_path / "paper"
    assert main(["ablate-beta", str(noisy_ico), "-o", str(out), "--size", str(SIZE),
                 "--betas", "0,1", "--grid-betas", "0,1", "--types", "points,triangles",
                 "--paper-parameters", "--scheduler", "serial"]) == 0
    printed = capsys.readouterr().out
    rows = _rows(out / beta_study.BETA_CSV)
    assert {(float(r["alpha"]), float(r["alpha_u"]), r["parameters"]) for r in rows} == {
        (beta_study.PAPER_ALPHA, beta_study.PAPER_ALPHA_U, "paper")}
    points = [r for r in rows if r["type"] == "points"]
    assert all(float(r["hit_fraction"]) < beta_study.MIN_ERROR_SHARE for r in points)
    assert all(r["error_rel_diag"] in ("", "nan") for r in points)
    params = json.loads((out / beta_study.BETA_PARAMS).read_text())
    assert params["paper_parameters"] is True and params["camera_vectors"] is None
    assert params["alpha"] == 200.0 and params["alpha_u"] == 1200.0
    assert "--paper-parameters" in params["parameters"]
    summary = next(ln for ln in printed.splitlines() if ln.startswith("Beta ablation of"))
    assert "the paper's parameters (--paper-parameters" in summary
    warning = [ln for ln in printed.splitlines() if ln.startswith("warning: points")]
    assert len(warning) == 1 and "undefined" in warning[0], printed


def test_beta_given_alpha_is_used_and_named(noisy_ico, tmp_path):
    """--alpha on a user's mesh: that alpha, the mesh's auto alpha_U for it, offset 0."""
    out = tmp_path / "given"
    assert main(["ablate-beta", str(noisy_ico), "-o", str(out), "--size", "16", "--betas", "0",
                 "--types", "triangles", "--alpha", "20", "-q"]) == 0
    (row,) = _rows(out / beta_study.BETA_CSV)
    assert float(row["alpha"]) == 20.0 and float(row["offset"]) == 0.0
    assert math.isclose(float(row["alpha_u"]), _auto(noisy_ico, "triangles").auto_alpha_u(20.0))
    assert row["parameters"] == "alpha given, alpha_U auto"
    report = (out / "report.md").read_text(encoding="utf-8")
    assert "alpha given, alpha_U auto: triangles alpha 20, alpha_U 400" in report


def _hit_fractions(info):
    return [r["hit_fraction"] for r in info["renders"]]


def test_alpha_on_a_users_mesh_scales_its_auto_alpha(noisy_ico, tmp_path, capsys):
    """ablate-alpha --mesh: the study's factors times the mesh's auto alpha, a framed camera,
    and every panel hit; the paper's alphas (--paper-parameters) leave the icosphere's points
    all but unhit, and say that they are the paper's."""
    out = tmp_path / "alpha"
    assert main(["ablate-alpha", "underestimate", "-o", str(out), "--mesh", str(noisy_ico),
                 "--kind", "points", "--size", str(SIZE), "--scheduler", "serial"]) == 0
    printed = capsys.readouterr().out
    info = json.loads((out / "underestimate.json").read_text())
    a0 = _auto(noisy_ico, "points").auto_alpha()
    factors = alpha_study.STUDY_DEFAULTS["underestimate"]["factors"]
    assert np.allclose(info["alphas"], [f * a0 for f in factors], rtol=1e-3)
    assert info["parameters"] == "auto" and "the mesh's auto α" in info["parameters_rule"]
    assert f"auto α {a0:.4g}" in info["title"] and f"auto α {a0:.4g}" in printed
    fractions = _hit_fractions(info)
    # one shared camera frames the largest (lowest alpha) surface: the nested ones are smaller
    assert fractions[0] > NON_TRIVIAL and min(fractions) > 0.01, fractions
    # the paper's alphas 25-200, said so, and almost no pixel hit
    out2 = tmp_path / "alpha-paper"
    assert main(["ablate-alpha", "underestimate", "-o", str(out2), "--mesh", str(noisy_ico),
                 "--kind", "points", "--size", str(SIZE), "--paper-parameters", "-q"]) == 0
    paper = json.loads((out2 / "underestimate.json").read_text())
    assert paper["alphas"] == alpha_study.STUDY_DEFAULTS["underestimate"]["alphas"]
    assert paper["parameters"] == "paper" and "--paper-parameters" in paper["title"]
    assert max(_hit_fractions(paper)) < 0.01, _hit_fractions(paper)


def test_alpha_metric_on_a_users_mesh(noisy_ico, tmp_path):
    """The metric figure on the icosphere's triangles: alphas from the triangles' auto alpha,
    named in the JSON and the report."""
    out = tmp_path / "metric"
    assert main(["ablate-alpha", "metric", "-o", str(out), "--mesh", str(noisy_ico),
                 "--size", "16", "-q"]) == 0
    info = json.loads((out / "metric.json").read_text())
    a0 = _auto(noisy_ico, "triangles").auto_alpha()
    factors = alpha_study.STUDY_DEFAULTS["metric"]["factors"]
    assert info["kind"] == "triangles"
    assert np.allclose(info["alphas"], [f * a0 for f in factors], rtol=1e-3)
    assert all(r["exact"]["hit_fraction"] > NON_TRIVIAL for r in info["renders"])
    assert "the mesh's auto α" in (out / "report.md").read_text(encoding="utf-8")


@pytest.fixture(scope="module")
def flat_gear(tmp_path_factory):
    """A flat toothed ring lying in the xy plane of a z-up STL (thickness 0.12, width 2): seen
    from the z-up convention's front it is a strip; tracer render looks at it face-on."""
    trimesh = pytest.importorskip("trimesh")
    parts = [trimesh.creation.annulus(0.3, 0.85, height=0.12)]
    for k in range(24):
        tooth = trimesh.creation.box((0.2, 0.09, 0.12))
        tooth.apply_translation((0.9, 0.0, 0.0))
        tooth.apply_transform(trimesh.transformations.rotation_matrix(2 * np.pi * k / 24,
                                                                      (0, 0, 1)))
        parts.append(tooth)
    path = tmp_path_factory.mktemp("gear") / "gear.stl"
    trimesh.util.concatenate(parts).export(path)
    return path


def _forward(camera):
    origin, dest = np.asarray(camera[0], float), np.asarray(camera[1], float)
    return (dest - origin) / np.linalg.norm(dest - origin)


def test_the_studies_orient_a_flat_mesh_as_tracer_render_does(flat_gear, tmp_path):
    """ablate-alpha and ablate-beta on a user's flat z-up gear: the camera looks along z, as
    tracer render's does (issue 61: the alpha figure showed the gear edge-on)."""
    out = tmp_path / "render.png"
    assert main(["render", str(flat_gear), "--size", "16", "16", "-o", str(out), "-q"]) == 0
    from tracer.scenes.from_mesh import mesh_scene

    want = _forward(mesh_scene(str(flat_gear), size=(16, 16)).camera)
    assert abs(want[2]) > 0.99, want
    alpha_out = tmp_path / "alpha"
    assert main(["ablate-alpha", "underestimate", "-o", str(alpha_out), "--mesh",
                 str(flat_gear), "--size", str(SIZE), "--scheduler", "serial", "-q"]) == 0
    info = json.loads((alpha_out / "underestimate.json").read_text())
    assert np.allclose(_forward(info["camera"]), want, atol=1e-6), info["camera"]
    beta_out = tmp_path / "beta"
    assert main(["ablate-beta", str(flat_gear), "-o", str(beta_out), "--size", "16",
                 "--betas", "0,1", "--types", "points"]) == 0
    params = json.loads((beta_out / "beta_params.json").read_text())
    assert np.allclose(_forward(params["camera_vectors"]), want, atol=1e-6), params["camera"]
    assert "as tracer render orients" in params["camera"]
