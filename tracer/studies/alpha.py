"""``tracer ablate-alpha STUDY``: the alpha figures of Sec. 3 as labelled image grids.

``underestimate`` (nested isosurfaces at increasing alpha), ``exact-smooth`` (smooth vs exact
offset surfaces), ``weights`` (weight functions on/off), ``metric`` (alpha-metric weight
gradient on/off) and ``attenuate`` (alpha_U attenuation on/off); ``all`` runs them all.

Parameters: the default data is rendered at the alphas of the paper's figures
(:data:`STUDY_DEFAULTS`) with the scenes' cameras. A mesh of your own (``--mesh``) is rendered
at alphas scaled from its own automatic alpha (``SmoothDistanceField.auto_alpha``, the
smallest alpha whose surface lies close to the data; the factors put the default data at
about the paper's alphas) with a camera framing it from the front, as ``tracer render`` does;
``--paper-parameters`` renders it at the paper's alphas with the paper's beta-study camera
instead, and ``--alphas`` at the given ones. Every figure's title, JSON (``parameters``,
``parameters_rule``) and log line say which.

"Weights off" (figure ``weights``, and the unweighted column of ``attenuate``) is realised by
:func:`tracer.studies.common.unweighted_field`: a copy of a field whose primitive table has the
raw weight polynomial ``A w~`` replaced by the constant 1 and whose node weight bounds ``whi``
are 1, so that the Barnes-Hut far field and the tracer's inflation margin use the unweighted
bound as well. Every term then has ``W = 1``, exactly the naive LogSumExp of Eq. 2 applied to
exact primitive distances.

As independent tasks: :func:`list_tasks` (one task per figure: its parameters),
:func:`study_task` (renders the figure's panels with one shared camera and returns the labelled
grid as PNG bytes with its JSON description) and :func:`reduce` (``report.md``). The PNG and
JSON of a figure are written as soon as it arrives.
"""

import io
import os
import time
from types import SimpleNamespace

import numpy as np

from tracer import runner
from tracer.errors import CLIError, RenderError
from tracer.outputs import (check_size, float_list, non_negative, output_folder, positive,
                            write_bytes, write_json, write_text)
from tracer.rendering.renderer import render
from tracer.runner import duration
from tracer.scenes.scene import scene_from_field
from tracer.studies.common import (REPO, TYPES, add_common, add_view_arguments, field_of,
                                   load_mesh_checked, render_orientation, resolve_view,
                                   study_needs, unweighted_field, view_camera)
from tracer.studies.plots import alpha_report, panel_grid_png, pyplot, significant

HELP = "the paper's alpha studies as image grids"

STUDIES = ("underestimate", "exact-smooth", "weights", "metric", "attenuate")

#: default data and cameras (the cameras of the matching scenes/*.json)
_LION = ("scenes/data/pointclouds/scan_guardian_lion_points.ply",
         ((0.035, -2.6, 0.07), (0.035, 0.0, 0.07), (0.0, 0.0, 1.0)))
_CAPILLARY = ("scenes/data/curves/capillary_networks.obj",
              ((0.0, 0.15, 4.2), (-0.03, 0.15, 0.0), (0.0, 1.0, 0.0)))
_OCTOPUS = ("scenes/data/meshes/octopus_low.obj",
            ((0.034, 0.049, 2.0), (0.034, 0.049, 0.082), (0.0, 1.0, 0.0)))
_TORUS = ("scenes/data/meshes/torus.obj",
          ((0.0, -3.6, 2.6), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)))
#: the data each study reads without ``--mesh`` (for :func:`needs`)
_DATA = {"underestimate": (_LION,), "exact-smooth": (_LION,), "weights": (_CAPILLARY, _OCTOPUS),
         "metric": (_TORUS,), "attenuate": (_OCTOPUS,)}

#: per study: the paper's alphas (its figures' data), and the factors of a mesh's auto alpha
#: (``SmoothDistanceField.auto_alpha``) used with --mesh; ``u_factor``: attenuate's alpha_U
#: over the auto alpha. The factors are the paper's alphas over the default data's auto alpha
#: (lion points 99.7: 25-200; capillary edges 63.3 and octopus triangles 148: 40 and 120;
#: torus triangles 54.4: 15 and 30; octopus 148: 20, 40 and alpha_U 300), rounded.
STUDY_DEFAULTS = {
    "underestimate": {"alphas": [25.0, 50.0, 100.0, 200.0], "factors": [0.25, 0.5, 1.0, 2.0]},
    "exact-smooth": {"alphas": [25.0, 50.0, 100.0, 200.0], "factors": [0.25, 0.5, 1.0, 2.0]},
    "weights": {"alphas": [40.0, 120.0], "factors": [0.75]},
    "metric": {"alphas": [15.0, 30.0], "factors": [0.25, 0.5]},
    "attenuate": {"alphas": [20.0, 40.0], "alpha_u": 300.0, "factors": [0.15, 0.3],
                  "u_factor": 2.0},
}


def default_output(size):
    return os.path.join("renders", "ablation", f"alpha-{size}")


def add_arguments(p):
    """Arguments of ``tracer ablate-alpha``."""
    p.add_argument("study", choices=STUDIES + ("all",),
                   help="which figure: underestimate (nested isosurfaces at increasing alpha), "
                   "exact-smooth (smooth vs exact offset), weights (on/off), metric (alpha-metric "
                   "gradient on/off), attenuate (alpha_U on/off), or all")
    p.add_argument("-o", "--output", metavar="DIR",
                   help="result folder: <study>.png, <study>.json and report.md (default "
                   "renders/ablation/alpha-<size>)")
    p.add_argument("--size", type=int, default=256, help="render size per panel (default 256)")
    p.add_argument("--mesh", help="use this mesh instead of the study's default data (alphas "
                   "scaled from the mesh's own auto alpha; camera: --view, else framing the "
                   "surface from the front, as tracer render does)")
    p.add_argument("--paper-parameters", action="store_true",
                   help="with --mesh: the paper's alphas (those of the default data) and the "
                   "paper's beta-study camera instead of the mesh's auto alpha and a framed "
                   "camera (they suit the paper's data, not necessarily this mesh)")
    p.add_argument("--kind", choices=TYPES,
                   help="with --mesh: primitive type to use (default: points for underestimate "
                   "and exact-smooth, triangles (else edges) for metric and attenuate)")
    p.add_argument("--alphas", help="comma-separated alphas (overrides the study's defaults; "
                   "weights: the alpha of each row)")
    p.add_argument("--alpha-u", type=float, help="attenuate: the alpha_U of the attenuated "
                   "column (default 300, the octopus scene's alpha_u; with --mesh 2 x the "
                   "mesh's auto alpha)")
    p.add_argument("--beta", type=float, default=0.5, help="Barnes-Hut beta (default 0.5)")
    p.add_argument("--shading", choices=("normals", "headlight"), default="normals",
                   help="panel shading (default: normals, i.e. gradient as colour)")
    p.add_argument("--no-frame", action="store_true",
                   help="keep the study's camera as is (default: move it so that the union of "
                   "the panels' silhouettes fills the frame)")
    add_view_arguments(p, "the default data's scene camera; with --mesh front, framing the "
                       "surface (with --paper-parameters the paper's beta-study camera)")
    p.add_argument("--overwrite", action="store_true", help="replace earlier results of a study")
    runner.add_arguments(p)
    add_common(p)


def list_tasks(studies, *, size, alphas, mesh, kind, beta, shading, alpha_u, no_frame,
               view=None, up=None, paper=False):
    """One task per figure (a dict of its parameters); weights are rough relative costs.
    ``view`` and ``up`` (None, ``"auto"``, ``"x"``, ``"y"`` or ``"z"``): frame the data as
    ``tracer render --view --up`` does instead of the study's camera. ``paper``: a ``mesh``
    at the paper's alphas and camera instead of its auto alpha and a framed camera."""
    mesh = os.path.abspath(mesh) if mesh else None
    return [{"key": s, "study": s, "size": int(size), "alphas": alphas, "mesh": mesh,
             "kind": kind, "beta": float(beta), "shading": shading, "alpha_u": alpha_u,
             "no_frame": bool(no_frame), "view": view, "view_up": up, "paper": bool(paper),
             "weight": {"underestimate": 3.0, "exact-smooth": 3.0}.get(s, 1.0)}
            for s in studies]


def study_task(task):
    """Render one figure; returns ``{"png": bytes, "info": dict, "panels": "RxC"}``."""
    args = SimpleNamespace(**task)
    t0 = time.perf_counter()
    panels, info = _STUDY_FUNCS[task["study"]](args, task["size"], task["alphas"])
    info.update(study=task["study"], size=task["size"], beta=task["beta"],
                seconds=round(time.perf_counter() - t0, 2), image=f"{_slug(task['study'])}.png")
    return {"png": panel_grid_png(panels, info["title"]), "info": info,
            "panels": f"{len(panels)}x{max(len(r) for r in panels)}"}


def needs(args):
    """The optional packages of the studies (:func:`tracer.studies.common.study_needs`; the
    lion scan of underestimate and exact-smooth is a PLY file, read by trimesh)."""
    studies = STUDIES if args.study == "all" else (args.study,)
    files = [args.mesh] if args.mesh else [REPO / d[0] for s in studies for d in _DATA[s]]
    return study_needs(args, files)


def run(args):
    """Run one alpha study (or all); returns the exit status (1 when a figure failed)."""
    sched, workers = runner.check_arguments(args)
    size = check_size(args.size, minimum=8)
    non_negative(args.beta, "--beta")
    if args.alpha_u is not None:
        positive(args.alpha_u, "--alpha-u")
    alphas = float_list(args.alphas, "--alphas", positive=True) if args.alphas else None
    studies = list(STUDIES) if args.study == "all" else [args.study]
    out = output_folder(args.output or default_output(size))
    for s in studies:
        for ext in (".png", ".json"):
            p = out / f"{_slug(s)}{ext}"
            if p.exists() and not args.overwrite:
                raise CLIError(f"{p} exists (pass --overwrite to replace it)")
    if args.mesh:
        load_mesh_checked(args.mesh)  # validate early
    # the up axis is resolved per figure, from its data file (auto: as tracer render guesses)
    view, up = (args.view or "front", args.up) if (args.view or args.up) else (None, None)
    out.mkdir(parents=True, exist_ok=True)
    tasks = list_tasks(studies, size=size, alphas=alphas, mesh=args.mesh, kind=args.kind,
                       beta=args.beta, shading=args.shading, alpha_u=args.alpha_u,
                       no_frame=args.no_frame, view=view, up=up,
                       paper=args.paper_parameters)
    # about a second per 256^2 panel: a cluster pays off for "all" at larger sizes only
    estimate = 8.0 * len(studies) * (size / 256) ** 2

    rules = {}  # study: its parameters in words

    def on_result(task, record):
        rules[task["study"]] = record["info"]["parameters_rule"]
        slug = _slug(task["study"])
        write_bytes(out / f"{slug}.png", record["png"])
        write_json(out / f"{slug}.json", record["info"])
        write_text(out / "report.md", reduce(out))

    def line(task, r):
        return (f"{task['study']}: {r['panels']} panels in {r['info']['seconds']:.1f} s, "
                f"{r['info']['parameters_rule']} -> {out / (_slug(task['study']) + '.png')}")

    info = runner.run_study(study_task, tasks, on_result=on_result, scheduler=sched,
                            workers=workers, estimate=estimate,
                            label=f"ablate-alpha {args.study}", quiet=args.quiet, line=line)
    if not args.quiet:
        print(f"Wrote {', '.join(_slug(s) + '.png' for s in studies)}, their JSON and "
              f"report.md in {out} ({info.describe()}, {duration(info.seconds)}); parameters: "
              + "; ".join(f"{s} {rules[s]}" for s in studies if s in rules) + ".")
    if info.failed:
        for key, err in info.failed:
            print(f"warning: {key} failed: {err}", flush=True)
        return 1
    return 0


def reduce(out):
    """``report.md`` of the figures present in ``out``."""
    return alpha_report(out, STUDIES)


def _slug(study):
    return study.replace("-", "_")


def _study_data(args, default, kind_default):
    """``(source, DataMesh of the kind, camera or None, from_override)``.

    With ``--mesh``, ``kind_default == "triangles"`` falls back to edges, then points, when the
    mesh has no triangles.
    """
    if args.mesh:
        kind = args.kind or kind_default
        if kind_default == "triangles" and not args.kind:
            m = load_mesh_checked(args.mesh)
            kind = "triangles" if len(m.triangles) else ("edges" if len(m.edges) else "points")
        return args.mesh, load_mesh_checked(args.mesh, kind), None, True
    return default[0], load_mesh_checked(REPO / default[0], kind_default), default[1], False


def _alphas_for(study, alphas, field, override, paper=False):
    """``(alphas, info)``: the figure's alphas (1 / scene units) and ``{"parameters":
    "given" | "auto" | "paper", "parameters_rule": a sentence}``: ``alphas`` as given, else
    with ``override`` (``--mesh``, without ``paper``) the study's factors times the mesh's auto
    alpha, else the paper's (:data:`STUDY_DEFAULTS`)."""
    if alphas:
        alphas = sorted(alphas)
        return alphas, _given(alphas)
    d = STUDY_DEFAULTS[study]
    if override and not paper:
        a0 = field.auto_alpha()
        out = [float(f"{a0 * f:.4g}") for f in d["factors"]]
        return out, _auto(out, d["factors"], a0)
    return list(d["alphas"]), _paper(d["alphas"], override)


def _given(alphas):
    return {"parameters": "given",
            "parameters_rule": f"α = {', '.join(f'{a:g}' for a in alphas)} (given, --alphas)"}


def _auto(alphas, factors, a0):
    return {"parameters": "auto",
            "parameters_rule": f"α = {', '.join(f'{a:g}' for a in alphas)}: "
            f"{', '.join(f'{f:g}' for f in factors)} × the mesh's auto α {a0:.4g}"}


def _paper(alphas, override):
    return {"parameters": "paper",
            "parameters_rule": f"α = {', '.join(f'{a:g}' for a in alphas)}: the paper's"
            + (" (--paper-parameters: chosen for the paper's data, not this mesh)"
               if override else "")}


def _camera(args, src, field, camera, alphas):
    """The figure's camera: with ``--view``, or for a mesh of your own (``--mesh`` without
    ``--paper-parameters``: oriented as ``tracer render`` orients it, the file's up convention
    or else the view that shows the data's largest silhouette), the data file ``src`` framed
    as ``tracer render`` frames it (its vertices grown by the inflation bound at the smallest
    alpha); else ``camera`` (the default data's scene camera) or the
    paper's beta-study camera."""
    view = getattr(args, "view", None)
    up = getattr(args, "view_up", None)
    path = src if os.path.isabs(src) else REPO / src
    own = getattr(args, "mesh", None) and not getattr(args, "paper", False)
    if not view and own and not up:
        view, up, _ = render_orientation(path, field.mesh)
    elif not view and own:
        view = "front"
    if view and isinstance(view, str):
        view, up = resolve_view(SimpleNamespace(view=view, up=up), path)
    if view:
        grow = field.inflation(min(alphas))
        return tuple(np.asarray(v, float) for v in view_camera(field, view, up, grow, args.size))
    return camera or _default_camera(field)


def _default_camera(field):
    """The paper's beta-study camera for ``field`` (as ``scene_from_field`` builds it)."""
    lo, hi = field.bounds
    c = 0.5 * (lo + hi)
    return (c + np.array([0.0, 0.0, 2.0 * float((hi - lo).max())]), c, np.array([0.0, 1, 0]))


def _scene(field, *, camera, size, alpha, alpha_u=None, beta, mode="smooth", shading="normals",
           gradient="metric", offset=None):
    return scene_from_field(field, alpha=alpha, alpha_u=alpha_u, beta=beta, camera=camera,
                            width=size, height=size, mode=mode, shading=shading,
                            gradient=gradient, offset=offset)


def _frame_camera(specs, camera, fill=0.86, probe=48):
    """Move ``camera`` (pan and dolly, same orientation) so that the union of the silhouettes
    of ``specs`` (``(field, scene kwargs)``, probed at ``probe`` px) fills ``fill`` of the
    frame. Never moves it back; returns the original camera when nothing is hit."""
    union = np.zeros((probe, probe), bool)
    for field, kw in specs:
        try:
            union |= render(_scene(field, camera=camera, size=probe, **kw)).hit
        except RenderError:
            return camera
    if not union.any():
        return camera
    rows, cols = np.nonzero(union)
    # the authors' image-plane coordinates (see tracer.rendering.camera): dx = col/W - 1/2,
    # dy = (H - 1 - row)/H - 1/2, at unit distance along `forward`
    dx0, dx1 = cols.min() / probe - 0.5, (cols.max() + 1) / probe - 0.5
    dy0, dy1 = (probe - 1 - rows.max()) / probe - 0.5, (probe - rows.min()) / probe - 0.5
    half = 0.5 * max(dx1 - dx0, dy1 - dy0) + 1.0 / probe
    k = half / (0.5 * fill)
    if k >= 1.0:
        return camera
    o, d, up = (np.asarray(v, float) for v in camera)
    f = d - o
    dist = float(np.linalg.norm(f))
    f /= dist
    h = np.cross(f, up)
    h /= np.linalg.norm(h)
    v = np.cross(h, f)
    shift = (0.5 * (dx0 + dx1) * h + 0.5 * (dy0 + dy1) * v) * dist
    d2 = d + shift
    return (d2 - f * dist * k, d2, up)


def _render_group(specs, camera, size, frame=True):
    """Render ``specs`` (``(field, scene kwargs)``) with one shared, optionally framed camera."""
    cam = _frame_camera(specs, camera, probe=min(48, size)) if frame else camera
    out = []
    for field, kw in specs:
        try:
            out.append(render(_scene(field, camera=cam, size=size, **kw)))
        except RenderError as exc:
            if cam is camera:
                raise CLIError(f"alpha {kw.get('alpha'):g}: {exc}") from None
            return _render_group(specs, camera, size, frame=False)
    return out, [np.asarray(c, float).round(6).tolist() for c in cam]


def _study_underestimate(args, size, alphas):
    src, mesh, camera, override = _study_data(args, _LION, args.kind or "points")
    field = field_of(mesh)
    alphas, par = _alphas_for("underestimate", alphas, field, override, args.paper)
    camera = _camera(args, src, field, camera, alphas)
    specs = [(field, dict(alpha=a, beta=args.beta, shading=args.shading)) for a in alphas]
    res, cam = _render_group(specs, camera, size, frame=not args.no_frame)
    row = [(f"α = {a:g}  ({significant(r.seconds)} s)", r.rgb) for a, r in zip(alphas, res)]
    # nesting on a slice through the data, perpendicular to the view direction
    slice_img, nest = _nesting_slice(field, alphas, args.beta, camera, size,
                                     n=min(160, max(32, size)))
    row.append(("zero sets on a slice (α ↑ = darker → lighter)", slice_img))
    info = {"title": f"Underestimate / nesting: {os.path.basename(src)} ({field.num_primitives} "
            f"{mesh.kind}), β={args.beta:g}; {par['parameters_rule']}", **par, "data": src,
            "kind": mesh.kind, "alphas": alphas,
            "camera": cam, "shading": args.shading,
            "renders": [{"alpha": a, **r.summary()} for a, r in zip(alphas, res)],
            "nesting": nest, "paper_figure": "underestimate",
            "note": "higher-alpha isosurfaces lie inside lower-alpha ones (LogSumExp with unit "
            "weights is non-decreasing in alpha); 'nesting.violations' counts slice samples "
            "where a higher alpha is inside (d_hat <= 0) but a lower alpha is not"}
    return [row], info


def _view_frame(field, camera):
    lo, hi = field.bounds
    c = 0.5 * (lo + hi)
    o, d, up = (np.asarray(v, float) for v in camera)
    f = d - o
    f /= np.linalg.norm(f)
    h = np.cross(f, up)
    h /= np.linalg.norm(h)
    v = np.cross(h, f)
    return c, f, h, v


def _nesting_slice(field, alphas, beta, camera, size, n=160, exact_n=32):
    """Zero sets of ``d_hat`` for each alpha on the plane through the bbox centre facing the
    camera, as an RGB image, and the nesting check over the ``n x n`` plane samples (at
    ``beta``, and exactly, at beta = 0, on an ``exact_n x exact_n`` subset)."""
    plt = pyplot()
    c, f, h, v = _view_frame(field, camera)
    lo, hi = field.bounds
    diag = float(np.linalg.norm(hi - lo))
    pts = field.mesh.used_vertices()
    half = 0.5 * diag * 0.8
    u = np.linspace(-half, half, n)
    U, Vv = np.meshgrid(u, u)
    Q = c + U.reshape(-1, 1) * h + Vv.reshape(-1, 1) * v
    def violations(Db):
        bad = 0
        for i in range(len(alphas)):
            for j in range(i + 1, len(alphas)):
                bad += int(np.sum((Db[j] <= 0) & (Db[i] > 0)))
        return bad

    D = [field.smooth_distance(Q, alpha=a, beta=beta)[0].reshape(n, n) for a in alphas]
    check = {f"violations_beta_{beta:g}": violations(D)}
    if beta > 0:
        # the exact sum costs N terms per sample: check it on every `step`-th sample only
        step = max(1, n // exact_n)
        Qs = Q.reshape(n, n, 3)[::step, ::step].reshape(-1, 3)
        check["exact_check_samples"] = int(Qs.shape[0])
        check["violations_beta_0"] = violations(
            [field.smooth_distance(Qs, alpha=a, beta=0.0)[0] for a in alphas])
    fig, ax = plt.subplots(figsize=(size / 100, size / 100), dpi=100)
    slab = np.abs((pts - c) @ f) < 0.01 * diag
    P = pts[slab] - c
    ax.plot(P @ h, P @ v, ",", color="0.35")
    cmap = plt.get_cmap("viridis")
    for i, a in enumerate(alphas):
        ax.contour(U, Vv, D[i], levels=[0.0], colors=[cmap(i / max(len(alphas) - 1, 1))],
                   linewidths=1.0)
    ax.set_xlim(-half, half)
    ax.set_ylim(-half, half)
    ax.set_aspect("equal")
    ax.axis("off")
    fig.subplots_adjust(0, 0, 1, 1)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    from PIL import Image  # Pillow (tracer extra): loaded on use

    buf.seek(0)
    img = np.asarray(Image.open(buf).convert("RGB"))
    return img, {"slice_samples": n * n, "alpha_pairs": len(alphas) * (len(alphas) - 1) // 2,
                 **check, "plane": "through the bbox centre, perpendicular to the view "
                 "direction; points within 1% of the diagonal of it are drawn grey"}


def _study_exact_smooth(args, size, alphas):
    src, mesh, camera, override = _study_data(args, _LION, args.kind or "points")
    field = field_of(mesh)
    alphas, par = _alphas_for("exact-smooth", alphas, field, override, args.paper)
    camera = _camera(args, src, field, camera, alphas)
    specs = []
    for a in alphas:
        specs.append((field, dict(alpha=a, beta=args.beta, mode="exact", offset=1.0 / a,
                                  shading=args.shading)))
    for a in alphas:
        specs.append((field, dict(alpha=a, beta=args.beta, shading=args.shading)))
    res, cam = _render_group(specs, camera, size, frame=not args.no_frame)
    n = len(alphas)
    exact_row = [(f"exact, offset 1/α = {1 / a:.3g}", r.rgb) for a, r in zip(alphas, res[:n])]
    smooth_row = [(f"smooth, α = {a:g}", r.rgb) for a, r in zip(alphas, res[n:])]
    stats = [{"alpha": a, "exact": re.summary(), "smooth": rs.summary()}
             for a, re, rs in zip(alphas, res[:n], res[n:])]
    info = {"title": f"Exact offset (top) vs smooth distance (bottom): {os.path.basename(src)}, "
            f"β={args.beta:g}; {par['parameters_rule']}", **par, "data": src, "kind": mesh.kind,
            "alphas": alphas,
            "camera": cam, "shading": args.shading, "renders": stats,
            "paper_figure": "exact_smooth"}
    return [exact_row, smooth_row], info


def _study_weights(args, size, alphas):
    if args.mesh:
        m = load_mesh_checked(args.mesh)
        cases = []
        if len(m.edges) or len(m.triangles):
            cases.append(("edges", args.mesh, m.as_kind("edges"), None))
        if len(m.triangles):
            cases.append(("triangles", args.mesh, m.as_kind("triangles"), None))
        if not cases:
            raise CLIError(f"weights: {args.mesh} has no edges or triangles (weights only "
                           "exist for edges and triangles)")
    else:
        cases = [("edges", _CAPILLARY[0], load_mesh_checked(REPO / _CAPILLARY[0], "edges"),
                  _CAPILLARY[1]),
                 ("triangles", _OCTOPUS[0], load_mesh_checked(REPO / _OCTOPUS[0], "triangles"),
                  _OCTOPUS[1])]
    d = STUDY_DEFAULTS["weights"]
    rows, stats, rules = [], [], []
    for i, (kind, src, mesh, camera) in enumerate(cases):
        field = field_of(mesh)
        if alphas:
            a = alphas[min(i, len(alphas) - 1)]
            par = _given([a])
        elif args.mesh and not args.paper:
            a0 = field.auto_alpha()
            a = float(f"{a0 * d['factors'][0]:.4g}")
            par = _auto([a], d["factors"], a0)
        else:
            a = d["alphas"][i]
            par = _paper([a], bool(args.mesh))
        rules.append(f"{kind} {par['parameters_rule']}")
        camera = _camera(args, src, field, camera, [a])
        kw = dict(alpha=a, beta=args.beta, shading=args.shading)
        (off, on), cam = _render_group([(unweighted_field(field), kw), (field, kw)], camera,
                                       size, frame=not args.no_frame)
        rows.append([(f"{kind}, weights off (α={a:g})", off.rgb),
                     (f"{kind}, weights on (A={field.weight_bound:.3g})", on.rgb)])
        stats.append({"kind": kind, "data": src, "alpha": a, "alpha_u": a, "S": 1.0,
                      "A": field.weight_bound, "camera": cam, "off": off.summary(),
                      "on": on.summary()})
    info = {"title": f"Weight functions off (left) / on (right), α_U = α (S = 1), "
            f"β={args.beta:g}; {'; '.join(rules)}", "parameters": par["parameters"],
            "parameters_rule": "; ".join(rules), "cases": stats, "shading": args.shading,
            "paper_figure": "weights",
            "weights_off": "unweighted_field(): raw weight A w~ forced to the constant 1 "
            "(wc[:,0]=1, other coefficients 0, pwhi=1, node whi=1, A=1)"}
    return rows, info


def _study_metric(args, size, alphas):
    src, mesh, camera, override = _study_data(args, _TORUS, "triangles")
    field = field_of(mesh)
    alphas, par = _alphas_for("metric", alphas, field, override, args.paper)
    camera = _camera(args, src, field, camera, alphas)
    specs = []
    for a in alphas:
        for g in ("exact", "metric"):
            specs.append((field, dict(alpha=a, alpha_u=a, beta=args.beta, shading=args.shading,
                                      gradient=g)))
    res, cam = _render_group(specs, camera, size, frame=not args.no_frame)
    rows, stats = [], []
    for i, a in enumerate(alphas):
        ex, me = res[2 * i], res[2 * i + 1]
        rows.append([(f"metric off: exact ∇d̂ (α={a:g})", ex.rgb),
                     (f"metric on: α-metric gradient (α={a:g})", me.rgb)])
        stats.append({"alpha": a, "exact": ex.summary(), "metric": me.summary()})
    info = {"title": f"α-metric weight gradient off (left) / on (right): "
            f"{os.path.basename(src)}, α_U = α, β={args.beta:g}; {par['parameters_rule']}",
            **par, "data": src, "kind": mesh.kind,
            "alphas": alphas, "camera": cam, "shading": args.shading, "renders": stats,
            "paper_figure": "metric",
            "note": "same isosurface; only the gradient used for shading differs: the weight "
            "gradient is scaled by 1/alpha (exact derivative of d_hat) or 1/alpha^2 (the "
            "paper's alpha-metric)"}
    return rows, info


def _study_attenuate(args, size, alphas):
    src, mesh, camera, override = _study_data(args, _OCTOPUS, "triangles")
    field = field_of(mesh)
    alphas, par = _alphas_for("attenuate", alphas, field, override, args.paper)
    camera = _camera(args, src, field, camera, alphas)
    d = STUDY_DEFAULTS["attenuate"]
    if args.alpha_u is not None:
        alpha_u, why = args.alpha_u, "given, --alpha-u"
    elif override and not args.paper:
        a0 = field.auto_alpha()
        alpha_u = float(f"{a0 * d['u_factor']:.4g}")
        why = f"{d['u_factor']:g} × the mesh's auto α"
    else:
        alpha_u, why = d["alpha_u"], "the paper's"
    par["parameters_rule"] += f"; α_U = {alpha_u:g} ({why})"
    unw = unweighted_field(field)
    specs = []
    for a in alphas:
        specs += [(field, dict(alpha=a, alpha_u=a, beta=args.beta, shading=args.shading)),
                  (field, dict(alpha=a, alpha_u=alpha_u, beta=args.beta, shading=args.shading)),
                  (unw, dict(alpha=a, beta=args.beta, shading=args.shading))]
    res, cam = _render_group(specs, camera, size, frame=not args.no_frame)
    rows, stats = [], []
    for i, a in enumerate(alphas):
        full, att, non = res[3 * i:3 * i + 3]
        S = field.attenuation(a, alpha_u)
        rows.append([(f"attenuation off: α_U = α = {a:g} (S=1)", full.rgb),
                     (f"on: α_U = {alpha_u:g} (S={S:.3g})", att.rgb),
                     (f"unweighted (α={a:g})", non.rgb)])
        stats.append({"alpha": a, "alpha_u": alpha_u, "S": S, "full": full.summary(),
                      "attenuated": att.summary(), "unweighted": non.summary()})
    info = {"title": f"Weight attenuation at low α: {os.path.basename(src)}, β={args.beta:g}; "
            f"{par['parameters_rule']}", **par, "data": src, "kind": mesh.kind,
            "alphas": alphas, "alpha_u": alpha_u, "A": field.weight_bound, "camera": cam,
            "shading": args.shading, "renders": stats, "paper_figure": "attenuate"}
    return rows, info


_STUDY_FUNCS = {"underestimate": _study_underestimate, "exact-smooth": _study_exact_smooth,
                "weights": _study_weights, "metric": _study_metric,
                "attenuate": _study_attenuate}
