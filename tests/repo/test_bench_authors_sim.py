"""``benchmarks/bench_authors_sim.py`` end to end, against a stand-in for the authors' simulator.

The stand-in is a small script that reads the simulation file as their ``rigid_body_simulator``
is called (``BIN FILE THREADS`` in the file's folder) and writes what theirs writes: a
``<name>__<object>__state.txt`` per dynamic object (one line per frame, ``x,y,z;R (9);v;w``)
and a ``<name>__<name>__times.txt`` with one time per distance evaluation. Its path is the
exact free fall, optionally shifted by a fixed offset, so the benchmark's deviation column can
be checked against a number known in advance.
"""

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SIM = ROOT / "tests" / "data" / "authors_sims" / "point_line.json"

STAND_IN = '''#!{python}
import json, sys
import numpy as np
spec = json.load(open(sys.argv[1]))
dt, g, n = spec["timestep"], np.array(spec["gravity"], float), spec["num_steps"]
for obj in spec["objects"]:
    if not obj.get("is_dynamic"):
        continue
    st = obj["init_state"]
    p0, v0 = np.array(st["position"], float), np.array(st["velocity"], float)
    with open(f"{{spec['name']}}__{{obj['name']}}__state.txt", "w") as fh:
        for k in range(n + 1):
            t = k * dt
            p = p0 + v0 * t + 0.5 * g * t * t + np.array({shift})
            v = v0 + g * t
            fh.write(",".join(map(str, p)) + ";1,0,0,0,1,0,0,0,1;" + ",".join(map(str, v))
                     + ";0,0,0\\n")
with open(f"{{spec['name']}}__{{spec['name']}}__times.txt", "w") as fh:
    fh.write(" ".join(["0.001"] * {evaluations}))
'''


def _stand_in(tmp_path, shift=(0.0, 0.0, 0.0), evaluations=7):
    exe = tmp_path / "fake_simulator"
    exe.write_text(STAND_IN.format(python=sys.executable, shift=list(shift),
                                   evaluations=evaluations))
    exe.chmod(0o755)
    return exe


def _run(tmp_path, exe, steps=5):
    out = tmp_path / "rows.json"
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_authors_sim.py"),
                           "--authors-bin", str(exe), str(SIM), "--steps", str(steps), "--threads", "1",
                           "--json", str(out)],
                          capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    [row] = json.loads(out.read_text())
    return row


@pytest.mark.slow
def test_free_fall_agrees_and_an_offset_path_is_measured(tmp_path):
    # the point falls freely for 5 steps of 0.01 (0.5 above the line at speed 1): ours and the
    # exact free fall differ by the integrator's O(g dt^2) only
    row = _run(tmp_path, _stand_in(tmp_path))
    assert row["steps"] == 5 and row["theirs_evaluations"] == 7
    assert row["ours_evaluations"] >= 0 and row["ours_s"] > 0 and row["theirs_s"] > 0
    assert row["max_path_deviation_pct"] < 0.1 and row["separated_at_step"] is None

    # a path shifted by 0.06 along x: the scene's size is the bodies' initial bounding box
    # (the line from x = -0.6 to 0.6, the point 0.5 above it): diagonal 1.3, so 4.6 %
    other = tmp_path / "shifted"
    other.mkdir()
    row = _run(other, _stand_in(other, shift=(0.06, 0.0, 0.0)))
    assert row["max_path_deviation_pct"] == pytest.approx(100 * 0.06 / 1.3, abs=0.05)
    assert row["separated_at_step"] == 0


def test_refuses_a_missing_binary(tmp_path):
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_authors_sim.py"),
                           "--authors-bin", str(tmp_path / "nothing"), str(SIM)],
                          capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert proc.returncode == 2 and "not an executable" in proc.stderr
