#!/usr/bin/env bash
# The test command: installs what it needs (.venv), then runs the whole test suite.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$root/scripts/bootstrap.sh" test
cd "$root"
exec python -m pytest -q "$@"
