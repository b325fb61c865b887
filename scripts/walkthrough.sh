#!/usr/bin/env bash
# The workbench loop of docs/workbench.md, end to end and unattended:
#   1. record the simulated plant with a hidden 0.3 s transport delay (closed loop, 300 s
#      chirp on lockstep sim time, at most 10x faster than the wall clock) into
#      WORKDIR/run1 (an MCAP bag);
#   2. fit the paper's model and compare;  3. diagnose;  4. add the named effect, refit,
#      compare again.
# Every command's output goes to the terminal and to WORKDIR/*.txt; reports to
# WORKDIR/report_*/index.html.
# Usage: bash scripts/walkthrough.sh [WORKDIR]        (default runs/walkthrough)
#        FIGURES=1 bash scripts/walkthrough.sh        also copies the report PNGs the docs
#                                                     show into docs/figures/workbench
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$root/scripts/bootstrap.sh" base
work="$(mkdir -p "${1:-$root/runs/walkthrough}" && cd "${1:-$root/runs/walkthrough}" && pwd)"
cfg="$root/config"
# a domain of our own, so a concurrent run (tests, another demo) cannot cross-talk
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$((100 + RANDOM % 100))}"
cd "$work"
rm -rf run1 report_base report_diag report_fitted

echo "== 1. record (hidden delay 0.3 s) on lockstep sim time, ROS_DOMAIN_ID=$ROS_DOMAIN_ID"
# Every node runs on the plant's /clock and the plant steps only once the controller has
# answered the last joint state (lockstep), so what is recorded does not depend on the
# machine's load. controller and setpoint wait for the clock; the plant starts sim time
# once controller and recorder read its joint states (start_subscribers) plus warmup_s, and
# exits after duration_s of sim time, so the bag holds sim time 0 .. 300 s.
pids=()
stop() { kill -INT "${pids[@]}" 2>/dev/null || true; wait "${pids[@]}" 2>/dev/null || true; }
trap stop EXIT
recorder --ros-args --params-file "$cfg/recorder.yaml" -p bag_path:="$work/run1" \
    -p use_sim_time:=true > recorder.log 2>&1 &
rec=$!
pids+=("$rec")
controller --ros-args --params-file "$cfg/controller.yaml" -p use_sim_time:=true \
    > controller.log 2>&1 &
pids+=($!)
setpoint --ros-args --params-file "$cfg/setpoint.yaml" -p profile:=chirp -p amplitude:=0.6 \
    -p chirp_end_hz:=0.3 -p chirp_duration_s:=300.0 -p use_sim_time:=true > setpoint.log 2>&1 &
pids+=($!)
plant_sim --ros-args --params-file "$cfg/plant_sim.yaml" -p accelerated:=true \
    -p lockstep:=true -p lockstep_timeout_s:=1.0 -p real_time_factor:=10.0 \
    -p start_subscribers:=2 -p warmup_s:=2.0 \
    -p duration_s:=300.0 -p delay_s:=0.3 > plant_sim.log 2>&1
pids=("${pids[@]:1}")
stop      # controller and setpoint (the plant has stopped: no joint state, no duty) ...
pids=("$rec")
sleep 1
stop      # ... then the recorder finalises the bag
trap - EXIT

run() { echo; echo "\$ sma-model $*"; sma-model "$@"; }
echo "== 2. fit the paper's model and compare"
run fit run1 --out base.yaml --force | tee fit_base.txt
run compare run1 --model base.yaml --report report_base --force | tee compare_base.txt
echo "== 3. diagnose"
run diagnose run1 --report report_diag --force | tee diagnose.txt
missing="$(sed -n 's/^missing effect: \([a-z_0-9]*\)$/\1/p' diagnose.txt)"
if [ -z "$missing" ]; then
  echo "diagnose found no significant missing effect; stopping here"; exit 0
fi
echo "== 4. add $missing and watch the error fall"
run fit run1 --model base.yaml --add "$missing" --out fitted.yaml --force | tee fit_fitted.txt
run compare run1 --model fitted.yaml --report report_fitted --force | tee compare_fitted.txt

if [ "${FIGURES:-0}" = 1 ]; then
  fig="$root/docs/figures/workbench"
  cp report_base/regimes.png "$fig/hidden_delay_regimes.png"
  cp report_base/correlation.png "$fig/hidden_delay_residual_tests.png"
  cp report_diag/time.png "$fig/hidden_delay_time.png"
  cp report_fitted/residual.png "$fig/hidden_delay_fitted_residual.png"
  echo "figures copied to $fig"
fi
echo; echo "reports: $work/report_{base,diag,fitted}/index.html"
