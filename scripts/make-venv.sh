#!/usr/bin/env bash
# Makes the virtual environment ($1, default .venv) with a supported Python (scripts/find-python.sh), and makes it
# again when it holds an unsupported one (e.g. made with a system Python 3.10 before this check existed).
set -euo pipefail
cd "$(dirname "$0")/.."
venv=${1:-.venv}

if [[ -x $venv/bin/python ]]; then
  if PYTHON=$venv/bin/python bash scripts/find-python.sh >/dev/null 2>&1; then
    exit 0
  fi
  echo "$venv was made with an unsupported Python: making it again" >&2
  rm -rf "$venv"
fi

python=$(bash scripts/find-python.sh)
minor=$("$python" -c 'import sys; print(sys.version_info[1])')
if ! "$python" -c 'import ensurepip, venv' 2>/dev/null; then
  # Debian and Ubuntu ship venv's pip bootstrap in a package of its own
  bash scripts/ensure-debs.sh "python3.$minor-venv"
fi
echo "Making $venv with $python (Python 3.$minor)"
"$python" -m venv "$venv"
"$venv/bin/python" -m pip install --quiet --upgrade pip
