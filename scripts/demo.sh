#!/usr/bin/env bash
# The main job: installs what it needs (.venv), then runs the simulated closed loop
# (plant_sim + controller + setpoint, step/ramp/sine, pi and pi_inverse) into runs/<name>/.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$root/scripts/bootstrap.sh" base
cd "$root"
exec closed_loop_demo "$@"
