#!/usr/bin/env bash
# The test command: installs what it needs (.venv), then runs the whole test suite.
# Arguments go to pytest: `bash scripts/test.sh -m "not slow"` is the quick run (about
# a minute; CI runs everything), `bash scripts/test.sh test/test_x.py` one file, `-n 0`
# in one process. Test files run side by side, one per core (pytest-xdist); each file stays
# in one process, so a module fixture is computed once.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$root/scripts/bootstrap.sh" test
cd "$root"
exec python -m pytest -q -n auto --dist loadfile "$@"
