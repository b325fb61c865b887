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
pi_inverse) it runs plant_sim (accelerated, owning /clock), controller and setpoint as
separate nodes on one executor in this process, talking over the real topics, and writes

  runs/<name>/summary.json        {"profiles": {profile: {mode: {"rms_error": rad,
                                    "max_error": rad, "settling_time": s or null}}}}
  runs/<name>/<profile>_<mode>.png setpoint and measured position vs time (+ duties)
  runs/<name>/<profile>_<mode>.csv the trace behind the figure
  runs/<name>/bags/<profile>_<mode>/ an MCAP bag of the run, when sma_actuator's recorder
                                    (sma_actuator.nodes.recorder.RecorderNode) is available

Metrics are taken from the start of each reference (t >= delay_s), settling band
`--tolerance` (default 0.025 rad = 5 % of the 0.5 rad amplitude); settling_time is null
when the response is still outside the band at the end of the run.
"""
import argparse
import csv
import json
from pathlib import Path
import time

import rclpy

from .control.metrics import summarize

# the references of Figs. 15-17: (setpoint parameters, run length [sim s])
REFERENCES = {
    'step': ({'profile': 'step', 'amplitude': 0.5, 'offset': 0.0, 'delay_s': 1.0}, 15.0),
    'ramp': ({'profile': 'ramp', 'amplitude': 0.5, 'offset': 0.0, 'period_s': 10.0,
              'delay_s': 1.0}, 20.0),
    'sine': ({'profile': 'sine', 'amplitude': 0.5, 'offset': 0.0, 'period_s': 20.0,
              'delay_s': 1.0}, 41.0),
}
MODES = ('pi', 'pi_inverse')


def recorder_factory(bag_dir):
    """
    Return the hook for MCAP recording.

    a factory(context) -> RecorderNode writing to bag_dir, or None when the recorder
    (sma_actuator.nodes.recorder) is not importable.
    """
    try:
        from .nodes.recorder import RecorderNode
    except ImportError:
        return None
    # the demo runs on the plant's accelerated /clock: log times must be sim time too
    return lambda context: RecorderNode(context=context, bag_path=str(bag_dir), use_sim_time=True)


def plot_response(path, title, t, setpoint, position, duty):
    """PNG like the paper's Figs. 15-17: desired and measured angle vs time, duties below."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, (ax, ax_d) = plt.subplots(2, 1, sharex=True, figsize=(8, 5),
                                   gridspec_kw={'height_ratios': [3, 1]})
    ax.plot(t, setpoint, 'k--', lw=1.2, label='setpoint')
    ax.plot(t, position, 'C0', lw=1.2, label='measured')
    ax.set_ylabel('shaft angle [rad]')
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(loc='best')
    ax_d.plot(t, duty[:, 0], 'C3', lw=0.8, label='duty a')
    ax_d.plot(t, duty[:, 1], 'C2', lw=0.8, label='duty b')
    ax_d.set_ylim(-0.05, 1.05)
    ax_d.set_xlabel('time [s]')
    ax_d.set_ylabel('duty')
    ax_d.grid(alpha=0.3)
    ax_d.legend(loc='upper right', fontsize='small')
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_csv(path, t, a):
    with open(path, 'w', newline='') as f:
        w = csv.writer(f)
        w.writerow(['time_s', 'setpoint_rad', 'position_rad', 'duty_a', 'duty_b',
                    'theta_a_c', 'theta_b_c'])
        for row in zip(t, a['setpoint'], a['position'], *a['duty'].T, *a['theta'].T):
            w.writerow([f'{v:.6g}' for v in row])


def run_all(context, out_dir, profiles=tuple(REFERENCES), modes=MODES, tolerance=0.025,
            real_time_factor=100.0, record=True, controller=None, plant=None, log=print):
    """Run every (profile, mode); write figures, traces and summary.json; return the summary."""
    from .nodes.harness import run_closed_loop
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    summary = {'profiles': {}}
    for profile in profiles:
        params, duration = REFERENCES[profile]
        for mode in modes:
            name = f'{profile}_{mode}'
            factory = recorder_factory(out_dir / 'bags' / name) if record else None
            t0 = time.monotonic()
            trace = run_closed_loop(context, params, duration, mode=mode,
                                    real_time_factor=real_time_factor, plant=plant,
                                    controller=controller, attach=[factory] if factory else ())
            a = trace.arrays()
            t = a['time_s'] - a['time_s'][0]
            m = summarize(t, a['setpoint'], a['position'], tolerance, t_start=params['delay_s'])
            summary['profiles'].setdefault(profile, {})[mode] = m
            plot_response(out_dir / f'{name}.png', f'{profile} response, mode {mode}', t,
                          a['setpoint'], a['position'], a['duty'])
            write_csv(out_dir / f'{name}.csv', t, a)
            settle = 'never' if m['settling_time'] is None else f"{m['settling_time']:.2f} s"
            log(f'{profile:5s} {mode:10s} rms {m["rms_error"]:.4f} rad  max '
                f'{m["max_error"]:.4f} rad  settling {settle}  '
                f'({duration:g} sim s in {time.monotonic() - t0:.1f} wall s'
                f'{", recorded" if factory else ""})')
    with open(out_dir / 'summary.json', 'w') as f:
        json.dump(summary, f, indent=2)
    return summary


def main(args=None):
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
    ns, ros_args = ap.parse_known_args(args)
    out = Path(ns.out_dir) / ns.name
    context = rclpy.context.Context()
    rclpy.init(args=ros_args, context=context)
    try:
        t0 = time.monotonic()
        run_all(context, out, ns.profiles, ns.modes, ns.tolerance, ns.real_time_factor,
                record=not ns.no_record,
                controller={'model_file': ns.model_file} if ns.model_file else None)
        print(f'wrote {out}/summary.json and {len(ns.profiles) * len(ns.modes)} figures '
              f'in {time.monotonic() - t0:.1f} s')
    finally:
        rclpy.try_shutdown(context=context)


if __name__ == '__main__':
    main()
