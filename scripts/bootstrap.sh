#!/usr/bin/env bash
# Create (or refresh) the project venv in .venv with the pinned dependencies and this
# package installed editable. Idempotent: re-runs only when a requirements file changed.
# Usage: source scripts/bootstrap.sh [base|test]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
set_name="${1:-test}"
venv="${SMA_VENV:-$root/.venv}"
py="${PYTHON:-python3.11}"
command -v "$py" >/dev/null 2>&1 || py=python3
if [ ! -x "$venv/bin/python" ]; then
  "$py" -m venv "$venv"
fi
stamp="$venv/.sma_stamp_$set_name"
want="$(cat "$root/requirements/"*.txt "$root/setup.py" | sha256sum | cut -c1-16)"
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
  "$venv/bin/python" -m pip install -q -r "$root/requirements/$set_name.txt" -c "$root/requirements/constraints.txt"
  "$venv/bin/python" -m pip install -q --no-deps --no-build-isolation -e "$root"
  echo "$want" > "$stamp"
fi
# editable installs put console scripts where ros2 run looks (lib/sma_actuator, from setup.cfg)
export PATH="$venv/lib/sma_actuator:$venv/bin:$PATH"
