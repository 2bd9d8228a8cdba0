#!/usr/bin/env bash
# Create .venv with a CPython between 3.10 and 3.13, preferring 3.11 (the reference interpreter: the
# one constraints.txt pins exactly and for which pybullet and the local CPU torch are binary wheels).
# Set PYTHON=/path/to/python3.X to choose another.
set -euo pipefail
venv="${1:-.venv}"
if [ -x "$venv/bin/python" ]; then exit 0; fi
candidates=("${PYTHON:-}" python3.11 python3.12 python3.13 python3.10 python3)
for py in "${candidates[@]}"; do
  [ -n "$py" ] || continue
  command -v "$py" > /dev/null 2>&1 || continue
  if "$py" -c 'import sys, venv; sys.exit(not ((3, 10) <= sys.version_info[:2] <= (3, 13)))' 2> /dev/null; then
    echo "create_venv: $venv with $("$py" --version) ($(command -v "$py"))"
    "$py" -m venv "$venv"
    "$venv/bin/python" -m pip install --quiet --upgrade "pip>=23.2"
    exit 0
  fi
done
echo "create_venv: no CPython 3.10 to 3.13 with the venv module found (set PYTHON=...)" >&2
exit 1
