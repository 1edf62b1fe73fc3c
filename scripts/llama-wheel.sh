#!/usr/bin/env bash
# A llama-cpp-python wheel built once for a portable CPU level, into a wheel folder of our own.
#
# Why: llama-cpp-python compiles llama.cpp from source, for the CPU it is built on. A CPU that announces AMX
# (Intel Sapphire Rapids and later) inside a virtual machine that does not enable it gets a library that dies
# with "illegal instruction" on the first token (seen on these machines). And pip's own wheel cache is keyed by
# the source, not by the build flags: it would hand back such a native build. So: x86-64 with AVX2/FMA/F16C (any
# x86 CPU since 2015), no AMX; other architectures (aarch64: the Jetson) build natively as before.
# Usage: scripts/llama-wheel.sh PYTHON WHEEL_DIR   (the range must match pyproject.toml's)
set -euo pipefail
python=$1
out=$2
spec="llama-cpp-python>=0.3,<0.4"
if ls "$out"/llama_cpp_python-*.whl >/dev/null 2>&1; then
    exit 0
fi
mkdir -p "$out"
case "$(uname -m)" in
    x86_64) export CMAKE_ARGS="-DGGML_NATIVE=OFF -DGGML_AVX=ON -DGGML_AVX2=ON -DGGML_FMA=ON -DGGML_F16C=ON -DGGML_BMI2=ON" ;;
esac
echo "building $spec once for this machine's CPU family (a few minutes): $out"
"$python" -m pip wheel --quiet --no-cache-dir --no-deps -w "$out" "$spec"
