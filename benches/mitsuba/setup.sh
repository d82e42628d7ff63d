#!/usr/bin/env bash
# Installs what benches/mitsuba/run.sh needs: a Python venv with Mitsuba 3 and Debian's
# LLVM 19 for its `llvm_ad_rgb` variant. Safe to run again: each step is skipped when
# it is already done.
#
#   benches/mitsuba/setup.sh            (the venv: target/mitsuba-venv, not committed)
#
# LLVM 14 and 15 abort on Mitsuba's path tracer ("Cannot select fminimum"); 19 works.
# Prints the two variables run.sh reads; run.sh also finds them by itself.
set -euo pipefail
cd "$(dirname "$0")/../.."
mitsuba_version=3.9.1
venv=${MITSUBA_VENV:-target/mitsuba-venv}
libllvm=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1

if ! [ -e "$libllvm" ]; then
    if [ "$(id -u)" != 0 ]; then
        echo "$libllvm missing: run 'apt-get install libllvm19' as root" >&2
        exit 2
    fi
    apt-get update -qq >&2
    apt-get install -y -qq libllvm19 >&2
fi
if ! [ -e "$libllvm" ]; then
    echo "$libllvm missing after installing libllvm19" >&2
    exit 2
fi

# Importing Dr.Jit makes its cache directory (by default ~/.drjit): a temporary one here.
DRJIT_CACHE_DIR=$(mktemp -d)
export DRJIT_CACHE_DIR
trap 'rm -rf "$DRJIT_CACHE_DIR"' EXIT

if ! [ -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
if ! "$venv/bin/python" -c "import mitsuba, sys; sys.exit(mitsuba.__version__ != '$mitsuba_version')" 2>/dev/null; then
    "$venv/bin/pip" install -q "mitsuba==$mitsuba_version"
fi

# Check that both variants load, and that the LLVM one finds LLVM 19.
DRJIT_LIBLLVM_PATH=$libllvm "$venv/bin/python" - <<'EOF'
import mitsuba as mi
for variant in ("scalar_rgb", "llvm_ad_rgb"):
    mi.set_variant(variant)
print("mitsuba", mi.__version__, "variants scalar_rgb and llvm_ad_rgb load")
EOF
echo "MITSUBA_VENV=$venv"
echo "DRJIT_LIBLLVM_PATH=$libllvm"
