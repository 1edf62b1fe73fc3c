#!/usr/bin/env bash
# Prints the path of a Python this project supports (pyproject.toml's requires-python: 3.11 to 3.13; mujoco 4
# needs 3.11 or newer). Looks at $PYTHON when it is set, else python3, python3.13, python3.12 and python3.11 on
# PATH, else uv's managed Python (installing one with uv when uv is there but has none). When there is none it
# says exactly how to get one and exits 1: Ubuntu 22.04 (JetPack 6 on a Jetson Orin) ships Python 3.10.
set -euo pipefail

MIN_MINOR=11 # Python 3.11 ...
MAX_MINOR=13 # ... to 3.13 (requires-python = ">=3.11,<3.14"; tests/app/test_python_setup.py keeps them equal)
PREFERRED=3.13
seen=""

minor_of() { # the minor version of Python 3 that "$1" runs, or nothing
  local version
  version=$("$1" -c 'import sys; print("%d.%d" % sys.version_info[:2])' 2>/dev/null) || return 0
  [[ $version =~ ^3\.([0-9]+)$ ]] && echo "${BASH_REMATCH[1]}"
  return 0
}

supported() { # prints the path and succeeds when "$1" is a supported Python
  local path minor
  path=$(command -v "$1" 2>/dev/null) || return 1
  minor=$(minor_of "$path")
  if [[ -n $minor ]] && ((minor >= MIN_MINOR && minor <= MAX_MINOR)); then
    echo "$path"
    return 0
  fi
  local what="not a Python that runs here"
  [[ -n $minor ]] && what="Python 3.$minor"
  seen="${seen:+$seen; }$1 is $what"
  return 1
}

if [[ -n ${PYTHON:-} ]]; then
  supported "$PYTHON" && exit 0
  echo "PYTHON=$PYTHON cannot be used: ${seen:-not found}; this project needs Python 3.$MIN_MINOR to 3.$MAX_MINOR." >&2
  exit 1
fi

for candidate in python3 "python3.$MAX_MINOR" python3.12 "python3.$MIN_MINOR"; do
  supported "$candidate" && exit 0
done

uv=$(command -v uv 2>/dev/null || true)
[[ -z $uv && -x $HOME/.local/bin/uv ]] && uv=$HOME/.local/bin/uv
if [[ -n $uv ]]; then
  range=">=3.$MIN_MINOR,<3.$((MAX_MINOR + 1))"
  found=$("$uv" python find "$range" 2>/dev/null || true)
  if [[ -z $found ]]; then
    echo "No Python 3.$MIN_MINOR-3.$MAX_MINOR here: installing Python $PREFERRED with uv ($uv)" >&2
    "$uv" python install "$PREFERRED" >&2 || true
    found=$("$uv" python find "$range" 2>/dev/null || true)
  fi
  if [[ -n $found ]] && supported "$found"; then
    exit 0
  fi
  seen="${seen:+$seen; }uv has none and could not install one"
fi

read -r -d '' message <<EOF || true
No Python 3.$MIN_MINOR to 3.$MAX_MINOR found (${seen:-no python3 on PATH}). mujoco 4 needs Python 3.$MIN_MINOR or newer, so the
system's older Python cannot run this project. Get one, then run make again; either of:

  # uv's managed Python (no root; uv comes from PyPI):
  python3 -m pip install --user uv && ~/.local/bin/uv python install $PREFERRED   # pip: python3-pip

  # Ubuntu 22.04 (JetPack 6), from the deadsnakes archive:
  sudo add-apt-repository -y ppa:deadsnakes/ppa
  sudo apt-get install -y python$PREFERRED python$PREFERRED-venv python$PREFERRED-dev

or name an interpreter: make run PYTHON=/path/to/python$PREFERRED
EOF
echo "$message" >&2
exit 1
