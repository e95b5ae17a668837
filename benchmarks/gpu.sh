#!/usr/bin/env bash
# The GPU path measured (issue 15), in under 5 minutes on one H100-class GPU: paper-size Transflower,
# DanceRevolution and TM2D generation (single stream and batched) and bf16 training (samples/s, MFU).
#
#   bash benchmarks/gpu.sh [gpu_bench.py options]      e.g. --compile, --gen-bf16, --recipes transflower
#   bash benchmarks/gpu.sh --smoke                     the same code on CPU with the small recipes
#
# Uses .venv/bin/python when present, else python3. Writes the measurements to $OUT/gpu_bench.json
# when OUT is set (the device machine's output folder), else benchmarks/gpu_bench.json is not written.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=.venv/bin/python
[ -x "$PY" ] || PY=python3
export OMP_NUM_THREADS="${OMP_NUM_THREADS:-4}"
"$PY" -c "import torch; print('# torch', torch.__version__, 'cuda', torch.cuda.is_available(), \
torch.cuda.get_device_name() if torch.cuda.is_available() else '')"
nvidia-smi --query-gpu=name,memory.total,clocks.max.sm,power.limit --format=csv,noheader 2>/dev/null || true
JSON=()
if [ -n "${OUT:-}" ]; then JSON=(--json "$OUT/gpu_bench.json"); fi
exec timeout "${GPU_BENCH_TIMEOUT:-290}" "$PY" benchmarks/gpu_bench.py "${JSON[@]}" "$@"
