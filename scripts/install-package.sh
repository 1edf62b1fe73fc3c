#!/usr/bin/env bash
# Installs this package ($2: "." or ".[test]") into the venv ($1) in editable mode. Binary wheels first; when some
# dependency has none for this machine (pocketsphinx on Python 3.12, e.g. on a Jetson's aarch64), the Debian
# packages a source build needs (scripts/build-debs.sh), then pip again, which builds it. With --build ($3) the
# build packages come first (the test tools always build llama-cpp-python).
set -euo pipefail
cd "$(dirname "$0")/.."
venv=$1
target=$2
build=${3:-}

if [[ $build != --build ]]; then
  errors=$(mktemp)
  trap 'rm -f "$errors"' EXIT
  if "$venv/bin/python" -m pip install --quiet --only-binary=:all: -e "$target" 2>"$errors"; then
    exit 0
  fi
  python=$("$venv/bin/python" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
  echo "Not every dependency has a wheel for Python $python on $(uname -m); building from source:" >&2
  grep -E '^ERROR' "$errors" >&2 || true
fi
# shellcheck disable=SC2046  # one word per package
bash scripts/ensure-debs.sh $(bash scripts/build-debs.sh "$venv")
if [[ $target == *test* ]]; then
  # llama-cpp-python from a wheel built once for a portable CPU level (scripts/llama-wheel.sh says why)
  wheels="${XDG_CACHE_HOME:-$HOME/.cache}/humanoid/wheels/llama-$(uname -m)"
  bash scripts/llama-wheel.sh "$venv/bin/python" "$wheels"
  "$venv/bin/python" -m pip install --quiet --no-deps "$wheels"/llama_cpp_python-*.whl
fi
"$venv/bin/python" -m pip install --quiet -e "$target"
