#!/usr/bin/env bash
# Prints the Debian packages that building a dependency from source needs with the venv's Python ($1, default
# .venv): a C and C++ compiler, cmake, and Python's headers when that Python is Debian's own (uv's and pyenv's
# carry theirs). Needed where a dependency has no wheel: pocketsphinx on Python 3.12 (aarch64 and x86_64 alike),
# llama-cpp-python everywhere. cmake older than a package wants (Ubuntu 22.04 has 3.22, pocketsphinx asks for
# 3.25) is no obstacle: scikit-build-core then takes cmake's own wheel from PyPI.
set -euo pipefail
venv=${1:-.venv}
packages=(build-essential cmake)
read -r prefix minor < <("$venv/bin/python" -c 'import sys; print(sys.base_prefix, sys.version_info[1])')
if [[ $prefix == /usr ]]; then
  packages+=("python3.$minor-dev")
fi
echo "${packages[*]}"
