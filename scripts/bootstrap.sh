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
  # ament_copyright (test/test_copyright.py) is on no reachable registry: vendored beside the clone
  vendor_copyright="$_sma_root/../shared/vendor/ament-copyright-jazzy"
  extra=()
  if [ "$_sma_set" = test ]; then
    if [ ! -f "$vendor_copyright/setup.py" ]; then
      echo "bootstrap: $vendor_copyright is missing (ament_copyright for the lint tests;" \
        "shared/ must sit beside the clone)" >&2
      exit 1
    fi
    extra=("$vendor_copyright/setup.py" "$vendor_copyright/package.xml")
  fi
  vendor="$_sma_root/../shared/vendor/ros2-launch-jazzy"
  want="$(cat "$_sma_root/requirements/"*.txt "$_sma_root/setup.py" "${extra[@]}" \
    "$_sma_root/scripts/bootstrap.sh" "$_sma_root/scripts/build_composition_interfaces.py" \
    | sha256sum | cut -c1-16)"
  if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
    "$_sma_venv/bin/python" -m pip install -q -r "$_sma_root/requirements/$_sma_set.txt" \
      -c "$_sma_root/requirements/constraints.txt"
    if [ "$_sma_set" = test ]; then
      # build from a copy: pip builds in tree and shared/ may be read-only
      tmp_src="$(mktemp -d)"
      cp -r "$vendor_copyright" "$tmp_src/ament_copyright"
      rm -rf "$tmp_src/ament_copyright/build" "$tmp_src/ament_copyright/"*.egg-info
      "$_sma_venv/bin/python" -m pip install -q --no-deps --no-build-isolation \
        "$tmp_src/ament_copyright"
      rm -rf "$tmp_src"
    fi
    "$_sma_venv/bin/python" -m pip install -q --no-deps --no-build-isolation -e "$_sma_root"
    # ROS 2 Jazzy launch system: no registry serves it; its PyPI deps are in requirements.
    # Built from a copy, as ament_copyright above.
    tmp_src="$(mktemp -d)"
    for pkg in launch launch_ros launch_xml launch_yaml; do
      cp -r "$vendor/$pkg" "$tmp_src/$pkg"
      rm -rf "$tmp_src/$pkg/build" "$tmp_src/$pkg/"*.egg-info
    done
    "$_sma_venv/bin/python" -m pip install -q --no-deps --no-build-isolation "$tmp_src/launch" \
      "$tmp_src/launch_ros" \
      "$tmp_src/launch_xml" "$tmp_src/launch_yaml"
    rm -rf "$tmp_src"
    "$_sma_venv/bin/python" "$_sma_root/scripts/build_composition_interfaces.py" \
      "$vendor/composition_interfaces" 2>&1 | grep -v -e '^Reading' -e '^Writing' -e 'duplicate entry'
    # what an ament_python install puts in share/: the ament index marker and share/<pkg>
    # (linked to the source tree, as the editable install links the code), so that
    # ament_index (ros2 launch, launch_ros Node, config_path) finds the package in the venv
    share="$_sma_venv/share"
    mkdir -p "$share/ament_index/resource_index/packages" "$share/sma_actuator"
    touch "$share/ament_index/resource_index/packages/sma_actuator"
    for item in package.xml config launch; do
      ln -sfn "$_sma_root/$item" "$share/sma_actuator/$item"
    done
    echo "$want" > "$stamp"
  fi
) || { echo "bootstrap: installing into $_sma_venv failed" >&2; return 1 2>/dev/null || exit 1; }
# editable installs put console scripts where ros2 run looks (lib/sma_actuator, from setup.cfg)
export PATH="$_sma_venv/lib/sma_actuator:$_sma_venv/bin:$PATH"
# the venv is an ament prefix (the ros-* wheels' share/ plus this package's marker)
case ":${AMENT_PREFIX_PATH:-}:" in
  *":$_sma_venv:"*) ;;
  *) export AMENT_PREFIX_PATH="$_sma_venv${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}" ;;
esac
unset _sma_root _sma_set _sma_venv
