#!/usr/bin/env bash
# Our renderer against Mitsuba 3 (llvm_ad_rgb, and scalar_rgb for reference) on the
# built-in scenes, the same thread counts, alternating in one run; prints a table.
#
#   benches/mitsuba/run.sh [--raytracer BIN] [--rounds 5] [--threads 1,2]
#                          [--scenes cornell,bunny,mixed,quads,spheres] [--warm 3]
#                          [--scalar-rounds 1] [--hold-avx2 auto|yes|no]
#                          [--pictures DIR] [--log FILE]
#
# BIN defaults to target/release/raytracer (build it first: cargo build --release).
# Runs setup.sh first (a venv with Mitsuba 3.9.1 and Debian's LLVM 19; quick once done).
# Every option is mitsuba_bench.py's `run` option: `mitsuba_bench.py run --help`.
set -euo pipefail
cd "$(dirname "$0")/../.."
export MITSUBA_VENV=${MITSUBA_VENV:-target/mitsuba-venv}
benches/mitsuba/setup.sh >/dev/null
export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1
exec "$MITSUBA_VENV/bin/python" benches/mitsuba/mitsuba_bench.py run "$@"
