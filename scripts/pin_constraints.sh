#!/usr/bin/env bash
# Re-pin constraints.txt from .venv (run after a deliberate change of requirements.txt).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
venv_py="$root/.venv/bin/python"
version="$("$venv_py" -c 'import sys; print(f"{sys.version_info[0]}.{sys.version_info[1]}")')"
{
  echo "# Exact versions of every package in .venv: pip freeze of the reference install (CPython $version, $(uname -m))."
  echo "# Other interpreters get only the pins and ranges of requirements.txt."
  echo "# Regenerate after changing requirements.txt: make constraints"
  "$venv_py" -m pip freeze --all --disable-pip-version-check \
    | grep -v -e '^-e ' -e '^pip==' -e ' @ ' \
    | sed -E 's/\+cpu$//; s/$/; python_version == "'"$version"'"/'
} > "$root/constraints.txt"
echo "pin_constraints: $(grep -c '==' "$root/constraints.txt") pins written to constraints.txt"
