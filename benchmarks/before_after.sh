#!/usr/bin/env bash
# Run one benchmark at an earlier revision and at the working tree, back to back in one
# run, so a refactor's figures can be compared under the same machine load.
# Usage: bash benchmarks/before_after.sh REV benchmarks/bench_x.py [ARGS ...]
# The earlier revision is checked out in a temporary git worktree beside this clone (so
# that ../shared resolves there too) and imported from there with this clone's .venv.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [ $# -lt 2 ]; then
  echo "usage: bash benchmarks/before_after.sh REV benchmarks/bench_x.py [ARGS ...]" >&2
  exit 2
fi
rev="$1"; shift
if ! git -C "$root" rev-parse -q --verify "$rev^{commit}" >/dev/null; then
  echo "before_after: unknown revision '$rev'" >&2
  exit 2
fi
source "$root/scripts/bootstrap.sh" test
py="$(command -v python)"
before="$(mktemp -d "$root/../.before_XXXXXX")"
trap 'git -C "$root" worktree remove --force "$before" >/dev/null 2>&1 || rm -rf "$before"' EXIT
git -C "$root" worktree add -q --detach "$before" "$rev"
echo "=== before: $(git -C "$before" log -1 --format='%h %s' | cut -c1-72)"
(cd "$before" && PYTHONPATH="$before" "$py" "$@")
echo "=== after: $(git -C "$root" log -1 --format='%h %s' | cut -c1-72)" \
  "$(git -C "$root" diff --quiet HEAD || echo '(+ uncommitted changes)')"
(cd "$root" && PYTHONPATH="$root" "$py" "$@")
