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

"""Properties of the hysteresis operators of the paper (eqs. 1-6) as implemented in core."""
import numpy as np
import pytest
from sma_actuator.core.hysteresis import (
    backlash_saturation_reference,
    ModifiedPrandtlIshlinskii,
    PlayHysteresis,
    PrandtlIshlinskii,
    PreisachModel,
)
from sma_actuator.core.major_loop import MajorLoopHysteresis

TIGHT = 1e-9   # float round-off on O(1) outputs; the laws themselves are exact


def classical_pi():
    """Eq. (5): 8 backlash elements, total h = 1 and K = 1 (the paper's Figs. 8-9)."""
    return PrandtlIshlinskii(np.arange(1, 9) / 8.0, np.full(8, 1.0 / 8.0))


def modified_pi():
    """Eq. (6): 8 elements with staggered widths and saturation levels."""
    h = np.arange(1, 9) / 8.0
    K = np.linspace(0.1, 0.2, 8)
    K1 = 0.1 * K
    M = np.linspace(0.2, 0.4, 8)
    return ModifiedPrandtlIshlinskii.from_paper(M, K, K1, h), (M, K, K1, h)


def ramp(*knots, step=0.01):
    """Piecewise-linear input through integer-grid knots (exactly repeatable values)."""
    idx = [int(round(k / step)) for k in knots]
    seq = [np.array([idx[0]])]
    for a, b in zip(idx[:-1], idx[1:]):
        seq.append(np.arange(a, b, 1 if b > a else -1)[1:].tolist() + [b])
    return np.concatenate([np.asarray(s) for s in seq]) * step


# (name, simulate(u), input amplitude centre, span, sign) : sign -1 for length (falls when heated)
MODELS = {
    'pi': (lambda u: classical_pi().simulate(u), 0.0, 2.0, 1),
    'modified_pi': (lambda u: modified_pi()[0].simulate(u), 0.0, 4.0, 1),
    'preisach': (lambda u: PreisachModel.grid(21).simulate(u), 0.0, 1.1, 1),
    'cosine': (lambda u: MajorLoopHysteresis(kind='cosine').simulate(u), 60.0, 35.0, -1),
    'ikuta': (lambda u: MajorLoopHysteresis(kind='ikuta').simulate(u), 60.0, 35.0, -1),
}


@pytest.mark.parametrize('name', sorted(MODELS))
def test_loop_closes_after_one_period(name):
    sim, c, a, _ = MODELS[name]
    period = 400
    u = c + a * np.sin(2 * np.pi * np.arange(3 * period + 1) / period)
    y = sim(u)
    # after the first cycle (initial loading) the loop repeats exactly
    np.testing.assert_allclose(y[period:2 * period + 1], y[2 * period:], atol=TIGHT)
    assert np.ptp(y[period:]) > 0.1 * np.ptp(y)   # and it is a real loop, not a constant


@pytest.mark.parametrize('name', sorted(MODELS))
def test_branches_are_monotone(name):
    sim, c, a, sign = MODELS[name]
    rng = np.random.default_rng(1)
    u = c + a * np.clip(np.cumsum(rng.normal(0, 0.05, 3000)), -1.2, 1.2)
    y = sign * sim(u)
    du, dy = np.diff(u), np.diff(y)
    assert (dy[du > 0] >= -TIGHT).all()
    assert (dy[du < 0] <= TIGHT).all()
    assert (np.abs(dy[du == 0]) <= TIGHT).all()


@pytest.mark.parametrize('make', [classical_pi, lambda: PreisachModel.grid(21)],
                         ids=['pi', 'preisach'])
def test_wiping_out_and_return_point_memory(make):
    # major descending branch from 1.5 (reference) vs the same with a minor loop -0.5..0.8
    major = ramp(-1.5, 1.5, -1.5)
    with_minor = ramp(-1.5, 1.5, -0.5, 0.8, -0.5, -1.5)
    y_major, y_minor = make().simulate(major), make().simulate(with_minor)
    # -0.5 is passed rising, then reached as the reversal, then again closing the minor loop
    i_rise, i_rev, i_back = np.flatnonzero(np.isclose(with_minor, -0.5))
    assert abs(y_minor[i_back] - y_minor[i_rev]) <= TIGHT            # returns to the reversal
    # inside the minor loop the output really left the major branch
    assert np.ptp(y_minor[i_rev:i_back + 1]) > 0.05
    # continues on the major descending branch (minor loop wiped out)
    tail_minor = y_minor[i_back:]
    j = int(np.flatnonzero(np.isclose(major, -0.5))[1])
    np.testing.assert_allclose(tail_minor, y_major[j:], atol=TIGHT)


def test_modified_pi_slopes_follow_eq6():
    model, (M, K, K1, h) = modified_pi()
    u_m = (K * h + M) / (K - K1)                # saturation thresholds of eq. (6)
    u_join = (K * h - M) / (K - K1)             # rising line K1 u - M meets K (u - h)
    assert u_join.max() < u_m.min()             # design: a stretch where all elements move
    u = np.linspace(-u_m.max() - 2, u_m.max() + 2, 4001)
    y = model.simulate(u)
    slope = np.gradient(y, u)
    beyond = (u > u_m.max() + 0.01) | (u < -u_m.max() - 0.01)
    np.testing.assert_allclose(slope[beyond][1:-1], K1.sum(), rtol=1e-7)
    inside = (u > u_join.max() + 0.01) & (u < u_m.min() - 0.01)
    np.testing.assert_allclose(slope[inside], K.sum(), rtol=1e-7)


def test_reference_eq6_equals_kernel():
    rng = np.random.default_rng(7)
    for _ in range(40):
        K = rng.uniform(0.2, 3.0)
        K1 = rng.uniform(0.0, 0.9) * K
        h, M = rng.uniform(0.0, 1.5), rng.uniform(0.05, 2.0)
        u = np.cumsum(rng.normal(0, 0.3, 300)) + rng.normal(0, 2)
        ref = backlash_saturation_reference(u, M, K, K1, h)
        ker = ModifiedPrandtlIshlinskii.from_paper([M], [K], [K1], [h]).simulate(u)
        np.testing.assert_allclose(ker, ref, atol=1e-9 * (1 + np.abs(ref).max()))


def _targets(lo, hi, n=1500, seed=3):
    """Output targets wandering inside (lo, hi): many reversals, hence minor loops."""
    rng = np.random.default_rng(seed)
    x = 0.5 + 0.45 * np.sin(np.linspace(0, 9, n)) * np.linspace(1, 0.3, n)
    x += np.cumsum(rng.normal(0, 0.004, n))
    return lo + (hi - lo) * np.clip(x, 0.02, 0.98)


@pytest.mark.slow
@pytest.mark.parametrize('form,u0', [('classical', -5.0), ('classical', 0.0),
                                     ('modified', 0.0),
                                     ('modified', -5.0)])
def test_inverse_reproduces_targets(form, u0):
    if form == 'classical':
        model, (lo, hi) = classical_pi(), (-2.0, 2.0)
    else:
        model = modified_pi()[0]
        lo, hi = model.output_range()
    y = _targets(lo, hi)
    inv = model.inverse()
    u = inv.simulate(y, u0=u0)
    back = model.simulate(u, s0=model.initial_state(u0))
    np.testing.assert_allclose(back, y, atol=1e-9 * (hi - lo))
    assert (np.diff(np.sign(np.diff(u))) != 0).sum() > 20   # minor loops were crossed
    # streaming inverse gives the same inputs
    inv.reset(u0)
    np.testing.assert_allclose([inv.step(v) for v in y[:200]], u[:200], atol=1e-12)


def test_preisach_grid_of_21_levels_has_231_relays():
    m = PreisachModel.grid(21, -1.0, 1.0)
    assert len(m.alpha) == len(m.beta) == len(m.mu) == 231 == 21 * 22 // 2
    assert (m.alpha >= m.beta).all()
    assert m.alpha.min() == -1.0 and m.alpha.max() == 1.0
    assert len({(a, b) for a, b in zip(m.alpha, m.beta)}) == 231
    # weights 1: output spans +-231 between full down and full up
    y = m.simulate(np.array([-1.5, 1.5]))
    assert y.tolist() == [-231.0, 231.0]


@pytest.mark.parametrize('kind', ['pi', 'modified', 'preisach', 'cosine', 'ikuta'])
def test_streaming_step_equals_batch(kind):
    rng = np.random.default_rng(5)
    if kind in ('cosine', 'ikuta'):
        u = 60 + np.clip(np.cumsum(rng.normal(0, 2, 500)), -40, 40)
        make = lambda: MajorLoopHysteresis(kind=kind)  # noqa: E731
    else:
        u = np.clip(np.cumsum(rng.normal(0, 0.1, 500)), -3, 3)
        make = {'pi': classical_pi, 'modified': lambda: modified_pi()[0],
                'preisach': lambda: PreisachModel.grid(21)}[kind]
    batch = make().simulate(u)
    m = make()
    np.testing.assert_allclose([m.step(v) for v in u], batch, atol=TIGHT)


def test_play_hysteresis_round_trips_through_dict():
    model = modified_pi()[0]
    copy = PlayHysteresis.from_dict(model.to_dict())
    u = np.linspace(-4, 4, 50)
    np.testing.assert_array_equal(copy.simulate(u), model.simulate(u))
