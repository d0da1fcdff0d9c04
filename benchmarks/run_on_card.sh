#!/usr/bin/env bash
# The measurements that need a machine with an NVIDIA card and many cores, in one script.
#
#   bash benchmarks/run_on_card.sh OUTDIR STEP...
#
# Steps, in the order given:
#   machine     the card, the CPU, the versions (machine.txt)
#   gpu         the GPU benchmark of issues 34 and 49: the bunny at 1920x1080 (normals) and the
#               1e6-point grid, GPU against every CPU core, with the thread blocks of $BLOCKS and
#               the kernel variants of $VARIANTS (a 32-bit stack, float32 boxes) timed too
#   gpu-lit     the lit look with 16 adaptive samples at 1920x1080, GPU against every core, and
#               the GPU's lit images of $IMAGE_KINDS (lit_KIND_gpu.png)
#   card        machine gpu gpu-lit: issue 49's table, about 8 minutes from a bare machine
#               (the two steps' limits add up to 600 s; the first launches compile the kernels)
#   regs        the normals frames and the grid with the kernels' registers capped
#               ($REG_VARIANTS, default regs128 regs64: more threads resident on each
#               multiprocessor, the rest spilled), beside the default kernels in the same
#               process; its own call (each variant compiles the cone and render kernels anew)
#   gpu-small   the GPU benchmark at 320x180 twice: an empty kernel cache, then a warm one
#               (the first-call compile time, and that numba-cuda's disk cache keeps the kernels)
#   scaling     the 1080p thread-scaling table of issue 32 for 1, 2, 4, ... up to every core
#   stored      the stored-value and golden-image tests on this CPU (pytest-xdist, 8 workers)
#   all         every step above
#
# Each step has its own time limit and writes its log and JSON into OUTDIR as it goes (the
# benchmark rewrites its JSON after each case), so that a step that runs out of time leaves
# what it finished. Kernels are cached in
# $NUMBA_CACHE_DIR (default /tmp/smoothdist-numba-cache), shared by the steps. The package is
# used from the checkout (PYTHONPATH); numpy, numba, numba-cuda and pillow must be importable.
set -u
out=${1:?output folder}
shift
mkdir -p "$out"
export PYTHONUNBUFFERED=1
export NUMBA_CACHE_DIR=${NUMBA_CACHE_DIR:-/tmp/smoothdist-numba-cache}
export PYTHONPATH=$PWD${PYTHONPATH:+:$PYTHONPATH}
py=${PYTHON:-python3}
cores=$(nproc)
threads=""
n=1
while [ "$n" -lt "$cores" ]; do threads="$threads $n"; n=$((n * 2)); done
threads="$threads $cores"

step() {  # step NAME SECONDS COMMAND...: runs it with a limit, its output to NAME.log
    local name=$1 limit=$2
    shift 2
    local t0=$SECONDS
    timeout "$limit" "$@" >"$out/$name.log" 2>&1
    local rc=$?
    echo "== $name: exit $rc in $((SECONDS - t0)) s"
    tail -n 25 "$out/$name.log"
}

steps=("$@")
[ "${steps[*]}" = all ] && steps=(machine gpu gpu-lit regs gpu-small scaling stored)
[ "${steps[*]}" = card ] && steps=(machine gpu gpu-lit)
for s in "${steps[@]}"; do
    case $s in
    machine)
        {
            nvidia-smi -L
            lscpu | grep -E 'Model name|^CPU\(s\)|Thread\(s\)|Socket'
            "$py" -c "import sys, numpy, numba, numba_cuda; print(sys.version.split()[0], 'numpy', numpy.__version__, 'numba', numba.__version__, 'numba-cuda', numba_cuda.__version__)"
        } >"$out/machine.txt" 2>&1
        cat "$out/machine.txt"
        ;;
    gpu-small)
        for cache in cold warm; do
            step "gpu_small_$cache" 200 "$py" benchmarks/bench_gpu.py --size 320 180 --grid 20 \
                --repeat 2 --json "$out/bench_gpu_small_$cache.json"
        done
        ;;
    gpu)
        # shellcheck disable=SC2086
        step gpu_1080p 300 "$py" benchmarks/bench_gpu.py --repeat 3 --blocks ${BLOCKS:-8x8 32x4} \
            --variants ${VARIANTS:-stack32 box32} --json "$out/bench_gpu.json"
        ;;
    gpu-lit)
        # issue 49: the lit look with 16 adaptive samples at 1080p, GPU against every core
        # shellcheck disable=SC2086
        step gpu_lit 300 "$py" benchmarks/bench_gpu.py --repeat 1 --cases lit \
            --kinds ${LIT_KINDS:-triangles points edges} \
            --images "$out" --image-kinds ${IMAGE_KINDS:-points triangles} \
            --json "$out/bench_gpu_lit.json"
        ;;
    regs)
        # issue 49 item 3: occupancy against spills (benchmarks/check_cuda_ptx.py --ptxas)
        # shellcheck disable=SC2086
        step gpu_regs 540 "$py" benchmarks/bench_gpu.py --repeat 3 --cases render grid \
            --variants ${REG_VARIANTS:-regs128 regs64} --json "$out/bench_gpu_regs.json"
        ;;
    scaling)
        # shellcheck disable=SC2086
        step scaling 200 "$py" benchmarks/bench_scaling.py --kinds points edges triangles \
            --threads $threads --repeat 2 --out "$out/scaling.json"
        ;;
    stored)
        step stored_values 300 "$py" -m pytest -p tracer.pytest_plugin -n 8 -q \
            -p no:cacheprovider tests/smoothdist/test_mesh_distance_unchanged.py \
            tests/smoothdist/test_mesh_distance_reference.py tests/tracer/rendering/test_render_golden.py \
            tests/tracer/rendering/test_render_determinism.py \
            tests/smoothdist/kernels/test_weights.py
        ;;
    *)
        echo "unknown step $s" >&2
        exit 2
        ;;
    esac
done
