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
Forward PI kernel throughput: numba kernel vs per-sample numpy loop vs plain C (gcc -O2).

1,000,000 samples x 16 play operators (classical PI, eq. 5, in the kernel's normalised
form). Prints operator updates per second for each and the kernel/C ratio (target >= 1/3),
then the streaming cost per call of `PlayHysteresis.step` and `AntagonisticActuator.step`
at 25 ms. Usage: python benchmarks/bench_pi_kernel.py
"""
import os
import shutil
import subprocess
import tempfile
import time

import numpy as np
from sma_actuator.core import actuator as act
from sma_actuator.core import kernels
from sma_actuator.core.hysteresis import PrandtlIshlinskii

N_SAMPLES, N_OPS, NUMPY_SLICE = 1_000_000, 16, 100_000

C_SOURCE = r"""
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
static double now(void) { struct timespec t; clock_gettime(CLOCK_MONOTONIC, &t);
                          return t.tv_sec + 1e-9 * t.tv_nsec; }
int main(int argc, char **argv) {
    long n = atol(argv[2]); int m = atoi(argv[3]);
    double *u = malloc(n * sizeof(double)), *y = malloc(n * sizeof(double));
    double r[64], w[64], s[64];
    FILE *f = fopen(argv[1], "rb");
    if (fread(r, sizeof(double), m, f) != (size_t)m || fread(w, sizeof(double), m, f) != (size_t)m
        || fread(u, sizeof(double), n, f) != (size_t)n) return 2;
    fclose(f);
    for (int i = 0; i < m; i++) s[i] = 0.0;
    double t0 = now();
    for (long k = 0; k < n; k++) {
        double uk = u[k], acc = 0.0;
        for (int i = 0; i < m; i++) {
            double v = s[i], a = uk - r[i], b = uk + r[i];
            v = v < a ? a : v;  v = v > b ? b : v;
            s[i] = v; acc += w[i] * v;
        }
        y[k] = acc;
    }
    double dt = now() - t0;
    double check = 0.0; for (long k = 0; k < n; k++) check += y[k];
    printf("%.6e %.17g\n", (double)n * m / dt, check);
    return 0;
}
"""


def make_input():
    """Decaying-sine input with noise (many reversals), and the 16-operator classical PI."""
    rng = np.random.default_rng(0)
    t = np.linspace(0, 200 * np.pi, N_SAMPLES)
    u = 3 * np.sin(t) * (1 - 0.7 * t / t[-1]) + 0.05 * rng.standard_normal(N_SAMPLES)
    model = PrandtlIshlinskii(np.linspace(0.0, 1.5, N_OPS), np.full(N_OPS, 1.0 / N_OPS))
    return u, model


def bench_kernel(u, m):
    """Updates/s of kernels.play_output (after a warm-up call) and its output."""
    args = (m.r, m.lo, m.hi, m.w, m.k1, m.y0, np.zeros(N_OPS))
    kernels.play_output(u[:1000], *args)
    t0 = time.perf_counter()
    y, _ = kernels.play_output(u, *args)
    return N_SAMPLES * N_OPS / (time.perf_counter() - t0), y


def bench_numpy(u, m):
    """Updates/s of a per-sample numpy loop over the state vector (100k-sample slice)."""
    s = np.zeros(N_OPS)
    y = np.empty(NUMPY_SLICE)
    t0 = time.perf_counter()
    for k in range(NUMPY_SLICE):
        s = np.minimum(np.maximum(s, u[k] - m.r), u[k] + m.r)
        y[k] = m.w @ s
    return NUMPY_SLICE * N_OPS / (time.perf_counter() - t0), y


def bench_c(u, m):
    """Updates/s reported by the compiled C loop, and its output checksum (None without gcc)."""
    if shutil.which('gcc') is None:
        return None, None
    with tempfile.TemporaryDirectory() as tmp:
        src, exe, data = (os.path.join(tmp, n) for n in ('pi.c', 'pi', 'input.bin'))
        with open(src, 'w') as f:
            f.write(C_SOURCE)
        subprocess.run(['gcc', '-O2', '-o', exe, src], check=True)
        with open(data, 'wb') as f:
            f.write(np.ascontiguousarray(m.r).tobytes() + np.ascontiguousarray(m.w).tobytes()
                    + np.ascontiguousarray(u).tobytes())
        out = subprocess.run([exe, data, str(N_SAMPLES), str(N_OPS)], check=True,
                             capture_output=True, text=True).stdout.split()
    return float(out[0]), float(out[1])


def bench_streaming(n_calls=20000):
    """Microseconds per PlayHysteresis.step and per AntagonisticActuator.step at 25 ms."""
    h = act.flexinol_hysteresis()
    temps = 60 + 30 * np.sin(np.linspace(0, 20, n_calls))
    h.step(temps[0])
    t0 = time.perf_counter()
    for v in temps:
        h.step(v)
    play_us = 1e6 * (time.perf_counter() - t0) / n_calls
    plant = act.AntagonisticActuator()
    duty = 0.5 + 0.5 * np.sin(np.linspace(0, 30, n_calls // 4))
    plant.step(0.3, 0.0, 0.025)
    t0 = time.perf_counter()
    for d in duty:
        plant.step(d, 1.0 - d, 0.025)
    return play_us, 1e6 * (time.perf_counter() - t0) / len(duty)


def main():
    """Run all benchmarks and print the figures side by side."""
    u, m = make_input()
    k_rate, y_kernel = bench_kernel(u, m)
    np_rate, y_np = bench_numpy(u, m)
    c_rate, c_check = bench_c(u, m)
    print(f'forward PI, {N_SAMPLES:,} samples x {N_OPS} operators (operator updates/s)')
    print(f'  numba kernel play_output : {k_rate:12.3e}')
    print(f'  numpy per-sample loop    : {np_rate:12.3e}   ({NUMPY_SLICE:,}-sample slice, '
          f'kernel/numpy = {k_rate / np_rate:.0f}x)')
    if c_rate is None:
        print('  C (gcc -O2)              : gcc not found')
    else:
        print(f'  C (gcc -O2)              : {c_rate:12.3e}')
        ratio = k_rate / c_rate
        print(f'  kernel / C               : {ratio:.2f}  (target >= 0.33: '
              f'{"met" if ratio >= 1 / 3 else "NOT met"})')
    agree_np = np.max(np.abs(y_np - y_kernel[:NUMPY_SLICE]))
    agree_c = abs(c_check - y_kernel.sum()) / max(1.0, abs(y_kernel.sum())) if c_rate else 0.0
    print(f'  outputs agree: numpy max|dy| = {agree_np:.1e}, C checksum rel. diff = {agree_c:.1e}')
    play_us, plant_us = bench_streaming()
    print('streaming cost per call')
    print(f'  PlayHysteresis.step (16 elements)        : {play_us:7.2f} us')
    print(f'  AntagonisticActuator.step (25 ms, 5 sub) : {plant_us:7.2f} us')


if __name__ == '__main__':
    main()
