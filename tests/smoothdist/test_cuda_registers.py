"""The register and occupancy report of ``benchmarks/check_cuda_ptx.py --ptxas`` (issue 49 item
3): its arithmetic, its reading of ``ptxas -v``, and the results file the performance guide
quotes. Assembling the kernels needs NVIDIA's NVVM and ``ptxas``, which CI does not install;
what is tested here runs without them."""

import json
from pathlib import Path

import pytest

from benchmarks.check_cuda_ptx import SM_LIMITS, occupancy, parse_ptxas

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "benchmarks" / "data" / "cuda_registers.json"

#: the tail of ``ptxas -arch=sm_90 -v`` for one kernel (CUDA 13), as the script reads it
REPORT = """ptxas info    : 11 bytes gmem
ptxas info    : Compiling entry function '_ZN8render_kernel' for 'sm_90'
ptxas info    : Function properties for _ZN8render_kernel
    2480 bytes stack frame, 3756 bytes spill stores, 3456 bytes spill loads
ptxas info    : Used 128 registers, used 0 barriers, 2480 bytes cumulative stack size
"""


def test_ptxas_report_is_read():
    assert parse_ptxas(REPORT) == {"registers": 128, "stack_bytes": 2480,
                                   "spill_stores": 3756, "spill_loads": 3456}
    with pytest.raises(ValueError, match="not a ptxas -v report"):
        parse_ptxas("ptxas fatal   : Unsupported .version 9.5")


@pytest.mark.parametrize("registers, threads, expected", [
    # worked by hand as NVIDIA's occupancy calculator does for compute capability 9.0:
    # 65536 registers, 64 warps and 32 blocks a multiprocessor, registers per warp in
    # units of 256, whole blocks
    (246, 64, 8 / 64),      # 31 units a warp -> 8 warps -> 4 blocks of 2 warps
    (255, 128, 8 / 64),     # 32 units -> 8 warps -> 2 blocks of 4
    (194, 128, 8 / 64),     # 25 units -> 10 warps -> 2 blocks of 4 (not 10 warps)
    (194, 64, 10 / 64),     # ... but 5 blocks of 2
    (120, 128, 16 / 64),    # 15 units -> 17 warps -> 4 blocks of 4
    (96, 64, 20 / 64),      # 12 units -> 21 warps -> 10 blocks of 2
    (64, 64, 32 / 64),      # 8 units -> 32 warps
    (32, 64, 1.0),          # 4 units -> 64 warps: the warp limit
    (16, 32, 32 / 64),      # the block limit: 32 blocks of one warp
    (255, 1024, 0.0),       # 8192 registers a warp x 32 warps: no block fits
])
def test_occupancy_is_worked_out_as_nvidia_does(registers, threads, expected):
    assert occupancy(registers, threads, (9, 0)) == expected


def test_occupancy_follows_the_compute_capability():
    # 8.6 (a GeForce RTX 30): 48 warps and 16 blocks a multiprocessor
    assert SM_LIMITS[(8, 6)][1:3] == (48, 16)
    assert occupancy(32, 64, (8, 6)) == 32 / 48        # 16 blocks of 2 warps
    assert occupancy(246, 64, (8, 6)) == 8 / 48


def test_the_results_file_agrees_with_itself():
    """Every kernel of the committed report: its occupancy is the one its registers and
    block give, a cap is kept (a capped kernel uses no more registers than its cap, and no
    fewer spills than uncapped), and the GPU path's kernels are all there."""
    report = json.loads(RESULTS.read_text())
    cc = tuple(report["cc"])
    names = {k["kernel"] for k in report["kernels"]}
    assert {"tracer.rendering.gpu_render render", "tracer.rendering.gpu_render cone",
            "tracer.rendering.gpu_render samples", "tracer.rendering.gpu_render light",
            "smoothdist.cuda smooth", "smoothdist.cuda exact"} <= names
    for k in report["kernels"]:
        base = k["assembled"][0]
        assert base["max_registers"] is None
        for a in k["assembled"]:
            assert a["occupancy"] == occupancy(a["registers"], k["threads_per_block"], cc)
            if a["max_registers"] is not None:
                assert a["registers"] <= a["max_registers"]
                assert a["spill_stores"] >= base["spill_stores"]
