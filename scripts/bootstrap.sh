#!/usr/bin/env bash
# Create (or refresh) the project venv in .venv with the pinned dependencies and this
# package installed editable, then put its console scripts on PATH.
# Idempotent: reinstalls only when a requirements file or setup.py changed.
# Usage: source scripts/bootstrap.sh [base|test]
# Safe to source from an interactive shell: strict mode lives in the install subshell only.
_sma_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
_sma_set="${1:-test}"
_sma_venv="${SMA_VENV:-$_sma_root/.venv}"
(
  set -euo pipefail
  py="${PYTHON:-python3.11}"
  command -v "$py" >/dev/null 2>&1 || py=python3
  if [ ! -x "$_sma_venv/bin/python" ]; then
    "$py" -m venv "$_sma_venv"
  fi
  stamp="$_sma_venv/.sma_stamp_$_sma_set"
  want="$(cat "$_sma_root/requirements/"*.txt "$_sma_root/setup.py" | sha256sum | cut -c1-16)"
  if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
    "$_sma_venv/bin/python" -m pip install -q -r "$_sma_root/requirements/$_sma_set.txt" \
      -c "$_sma_root/requirements/constraints.txt"
    "$_sma_venv/bin/python" -m pip install -q --no-deps --no-build-isolation -e "$_sma_root"
    echo "$want" > "$stamp"
  fi
) || { echo "bootstrap: installing into $_sma_venv failed" >&2; return 1 2>/dev/null || exit 1; }
# editable installs put console scripts where ros2 run looks (lib/sma_actuator, from setup.cfg)
export PATH="$_sma_venv/lib/sma_actuator:$_sma_venv/bin:$PATH"
unset _sma_root _sma_set _sma_venv
