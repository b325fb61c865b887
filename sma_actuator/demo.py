# Copyright 2026 sma_actuator developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
closed_loop_demo: the simulated closed loop end to end (the README's main command).

For each reference (step, ramp, sine: the paper's Figs. 15-17) and each mode (pi,
pi_inverse) it runs plant_sim (accelerated and lockstep, owning /clock), controller and
setpoint as separate nodes on one executor in this process, talking over the real topics,
and writes

  runs/<name>/summary.json          {"profiles": {profile: {mode: metrics}}}, see below
  runs/<name>/<profile>.png         setpoint and both modes' positions vs time, duties below
  runs/<name>/<profile>_<mode>.csv  the trace behind the figure
  runs/<name>/bags/<profile>_<mode>/ an MCAP bag of the run, when sma_actuator's recorder
                                    (sma_actuator.nodes.recorder.RecorderNode) is available

Metrics (`sma_actuator.control.metrics`; from the start of each reference, t >= delay_s):
  every profile  rms_error_rad, max_error_rad
  step           rise_time_s (10-90 %), overshoot_pct, steady_state_error_rad (mean of
                 the last 2 s), settling_time_s
  ramp           steady_state_error_rad, settling_time_s (from the end of the ramp)
  sine           phase_lag_s and phase_lag_deg (positive: the shaft trails), gain (amplitude
                 ratio), over the second period
settling_time_s is the time until |e| stays within `--tolerance` (default 0.025 rad = 5 %
of the 0.5 rad amplitude), null when the run ends outside the band; a sine has none.
The loop runs in lockstep on sim time, so the figures do not depend on the host's load.
An existing `--name` is refused (exit 2) unless `--force` is given.
"""
from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path
import sys
import time
from typing import Any, Callable, Dict, Iterable, Optional, Sequence, Tuple, TYPE_CHECKING

import numpy as np
import rclpy
from rclpy.context import Context

from .control import metrics

if TYPE_CHECKING:
    from .nodes.recorder import RecorderNode

# the references of Figs. 15-17: (setpoint parameters, run length [sim s])
REFERENCES = {
    'step': ({'profile': 'step', 'amplitude': 0.5, 'offset': 0.0, 'delay_s': 1.0}, 15.0),
    'ramp': ({'profile': 'ramp', 'amplitude': 0.5, 'offset': 0.0, 'period_s': 10.0,
              'delay_s': 1.0}, 20.0),
    'sine': ({'profile': 'sine', 'amplitude': 0.5, 'offset': 0.0, 'period_s': 20.0,
              'delay_s': 1.0}, 41.0),
}
MODES = ('pi', 'pi_inverse')


def recorder_factory(bag_dir: Path | str,
                     overwrite: bool = False) -> Optional[Callable[[Context], RecorderNode]]:
    """
    Return a factory(context) -> RecorderNode writing to bag_dir, for MCAP recording.

    None when the recorder (sma_actuator.nodes.recorder) is not importable.
    """
    try:
        from .nodes.recorder import RecorderNode
    except ImportError:
        return None
    # the demo runs on the plant's accelerated /clock: log times must be sim time too
    return lambda context: RecorderNode(context=context, bag_path=str(bag_dir),
                                        use_sim_time=True, overwrite=overwrite)


def plot_profile(path: Path | str, title: str,
                 runs: Dict[str, Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]) -> None:
    """
    Write a PNG like the paper's Figs. 15-17 with every mode overlaid.

    runs: {mode: (t [s], setpoint [rad], position [rad], duty (n, 2))}; the duty panel
    shows the net command u = duty_a − duty_b of each mode.
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, (ax, ax_d) = plt.subplots(2, 1, sharex=True, figsize=(8, 5),
                                   gridspec_kw={'height_ratios': [3, 1]})
    first = next(iter(runs.values()))
    ax.plot(first[0], first[1], 'k--', lw=1.2, label='setpoint')
    for k, (mode, (t, _, position, duty)) in enumerate(runs.items()):
        ax.plot(t, position, f'C{k}', lw=1.2, label=f'measured, {mode}')
        ax_d.plot(t, duty[:, 0] - duty[:, 1], f'C{k}', lw=0.8, label=mode)
    ax.set_ylabel('shaft angle [rad]')
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(loc='best')
    ax_d.set_ylim(-1.05, 1.05)
    ax_d.set_xlabel('time [s]')
    ax_d.set_ylabel('duty a − b')
    ax_d.grid(alpha=0.3)
    ax_d.legend(loc='upper right', fontsize='small')
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def profile_metrics(profile: str, t: np.ndarray, setpoint: np.ndarray, position: np.ndarray,
                    tolerance: float) -> Dict[str, Optional[float]]:
    """Return the summary.json metrics of one run of reference `profile` (module doc)."""
    params, _ = REFERENCES[profile]
    t0 = params['delay_s']
    keep = t >= t0
    m = {'rms_error_rad': metrics.rms_error(setpoint[keep], position[keep]),
         'max_error_rad': metrics.max_error(setpoint[keep], position[keep])}
    if profile == 'step':
        m.update(rise_time_s=metrics.rise_time(t, setpoint, position, t0),
                 overshoot_pct=metrics.overshoot_pct(t, setpoint, position, t0),
                 steady_state_error_rad=metrics.steady_state_error(t, setpoint, position),
                 settling_time_s=metrics.settling_time(t, setpoint, position, tolerance, t0))
    elif profile == 'ramp':
        end = t0 + params['period_s']
        m.update(steady_state_error_rad=metrics.steady_state_error(t, setpoint, position),
                 settling_time_s=metrics.settling_time(t, setpoint, position, tolerance, end))
    elif profile == 'sine':
        period = params['period_s']
        # the second period on: the first holds the start-up transient
        start = t0 + period if t[-1] - t0 >= 2 * period else t0
        m.update(metrics.phase_lag(t, setpoint, position, period, start))
    return m


def write_csv(path: Path | str, t: np.ndarray, a: Dict[str, np.ndarray]) -> None:
    """Write the trace behind a figure: time [s], setpoint and position [rad], duties, °C."""
    with open(path, 'w', newline='') as f:
        w = csv.writer(f)
        w.writerow(['time_s', 'setpoint_rad', 'position_rad', 'duty_a', 'duty_b',
                    'theta_a_c', 'theta_b_c'])
        for row in zip(t, a['setpoint'], a['position'], *a['duty'].T, *a['theta'].T):
            w.writerow([f'{v:.6g}' for v in row])


def run_all(context: Context, out_dir: Path | str, profiles: Iterable[str] = tuple(REFERENCES),
            modes: Iterable[str] = MODES, tolerance: float = 0.025,
            real_time_factor: float = 100.0, record: bool = True,
            controller: Optional[Dict[str, Any]] = None,
            plant: Optional[Dict[str, Any]] = None, log: Callable[[str], Any] = print,
            overwrite: bool = False) -> Dict[str, Any]:
    """Run every (profile, mode); write figures, traces and summary.json; return the summary."""
    from .in_process import run_closed_loop
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    summary = {'profiles': {}}
    for profile in profiles:
        params, duration = REFERENCES[profile]
        runs = {}
        for mode in modes:
            name = f'{profile}_{mode}'
            factory = (recorder_factory(out_dir / 'bags' / name, overwrite) if record
                       else None)
            t0 = time.monotonic()
            # lockstep: a loaded host only slows the run down, so the wall-time limit only
            # catches a loop that is stuck
            trace = run_closed_loop(context, params, duration, mode=mode,
                                    real_time_factor=real_time_factor, plant=plant,
                                    controller=controller, attach=[factory] if factory else (),
                                    wall_timeout_s=60.0 + 10.0 * duration)
            a = trace.arrays()
            t = a['time_s'] - a['time_s'][0]
            m = profile_metrics(profile, t, a['setpoint'], a['position'], tolerance)
            summary['profiles'].setdefault(profile, {})[mode] = m
            runs[mode] = (t, a['setpoint'], a['position'], a['duty'])
            write_csv(out_dir / f'{name}.csv', t, a)
            log(f'{profile:5s} {mode:10s} {describe(m)}  ({duration:g} sim s in '
                f'{time.monotonic() - t0:.1f} wall s{", recorded" if factory else ""})')
        plot_profile(out_dir / f'{profile}.png', f'{profile} response', runs)
    with open(out_dir / 'summary.json', 'w') as f:
        json.dump(summary, f, indent=2)
    return summary


# plant settings the harness owns (it runs the plant accelerated and in lockstep)
_HARNESS_PLANT = ('accelerated', 'lockstep', 'lockstep_timeout_s', 'real_time_factor',
                  'start_subscribers', 'warmup_s', 'duration_s')


def record_run(bag_dir: Path | str, duration_s: float, setpoint: Dict[str, Any],
               plant: Optional[Dict[str, Any]] = None,
               controller: Optional[Dict[str, Any]] = None,
               real_time_factor: float = 100.0) -> int:
    """
    Record a closed-loop run of `duration_s` sim seconds into the MCAP bag `bag_dir`.

    plant_sim, controller, setpoint and the recorder run as nodes on one executor on the
    plant's lockstep sim time, like the demo, so the bag is the same on any host load.
    Each node starts from its config/<node>.yaml (the `/**` section) with `plant`,
    `controller` and `setpoint` overrides on top. Return the number of recorded messages.
    """
    import yaml

    from .nodes.common import config_path
    from .in_process import run_closed_loop

    def config(name: str, drop: Iterable[str] = ()) -> Dict[str, Any]:
        """Return the `/**` parameters of config/<name>.yaml without the `drop` keys."""
        with open(config_path(f'{name}.yaml')) as f:
            values = yaml.safe_load(f)['/**']['ros__parameters']
        return {k: v for k, v in values.items() if k not in drop}

    context = rclpy.context.Context()
    rclpy.init(context=context)
    try:
        recorder = []

        def factory(ctx: Context) -> RecorderNode:
            """Make the recorder node and keep it, to count its messages after the run."""
            recorder.append(recorder_factory(bag_dir)(ctx))
            return recorder[-1]

        run_closed_loop(context, {**config('setpoint'), **setpoint}, duration_s,
                        real_time_factor=real_time_factor,
                        plant={**config('plant_sim', _HARNESS_PLANT), **(plant or {})},
                        controller={**config('controller'), **(controller or {})},
                        attach=[factory], wall_timeout_s=120.0 + 10.0 * duration_s)
        return recorder[0].bag.message_count
    finally:
        rclpy.try_shutdown(context=context)


def describe(m: Dict[str, Optional[float]]) -> str:
    """Return one log line of a run's metrics, with units."""
    parts = []
    for key, value in m.items():
        name, unit = key, ''
        for suffix in ('_rad', '_pct', '_deg', '_s'):
            if key.endswith(suffix):
                name, unit = key[:-len(suffix)], ' ' + {'_pct': '%'}.get(suffix, suffix[1:])
                break
        parts.append(f'{name} ' + ('none' if value is None else f'{value:.4g}{unit}'))
    return ', '.join(parts)


def main(args: Optional[Sequence[str]] = None) -> None:
    """Run the demo from the command line (see the module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument('--name', default=time.strftime('demo_%Y%m%d_%H%M%S'),
                    help='run name: output goes to <out-dir>/<name>/')
    ap.add_argument('--out-dir', default='runs')
    ap.add_argument('--profiles', nargs='+', default=list(REFERENCES), choices=list(REFERENCES))
    ap.add_argument('--modes', nargs='+', default=list(MODES), choices=list(MODES))
    ap.add_argument('--tolerance', type=float, default=0.025, help='settling band [rad]')
    ap.add_argument('--real-time-factor', type=float, default=100.0,
                    help='upper bound on sim/wall speed (the loop runs in lockstep)')
    ap.add_argument('--model-file', default='', help='controller model YAML '
                    '(default config/controller_model.yaml)')
    ap.add_argument('--no-record', action='store_true', help='skip the MCAP bags')
    ap.add_argument('--force', action='store_true',
                    help='write into an existing <out-dir>/<name>/ (replacing its files)')
    ns, ros_args = ap.parse_known_args(args)
    out = Path(ns.out_dir) / ns.name
    if out.exists() and not ns.force:
        print(f'closed_loop_demo: {out} already exists; choose another --name or use --force '
              'to replace it', file=sys.stderr)
        sys.exit(2)
    context = rclpy.context.Context()
    rclpy.init(args=ros_args, context=context)
    try:
        t0 = time.monotonic()
        run_all(context, out, ns.profiles, ns.modes, ns.tolerance, ns.real_time_factor,
                record=not ns.no_record,
                controller={'model_file': ns.model_file} if ns.model_file else None,
                overwrite=ns.force)
        print(f'wrote {out}/summary.json and {len(ns.profiles)} figures '
              f'in {time.monotonic() - t0:.1f} s')
    finally:
        rclpy.try_shutdown(context=context)


if __name__ == '__main__':
    main()
