"""Hidden-effect tests of `diagnose`: data from the independent rich simulator
(test/support/richsim.py: Preisach hysteresis, RK4 thermal model, its own formulation of
every effect) with one hidden effect at a time, plus a null case.

STRONG cases: diagnose names the hidden effect first and adding it cuts the held-out
NRMSE by at least 40 %; on the null cases nothing is significant. Cases vary magnitude,
excitation (open/closed loop), noise and sample rate (20-100 Hz).

WEAK cases are records where the effect is real but the held-out window is not a fair
test of it: phase resistance (~15 % more heating power while a wire is martensitic) shows
mostly in a regime the training window hardly visits (base NRMSE 0.74 % training, 2.6 %
held-out; 0.12 / 0.38 % on the null twin), so kappa fitted on the training window recovers
only about a quarter of the held-out error. For
them the tested property is the one that still matters to an engineer: diagnose never
names a wrong effect, and when it names the right one the held-out error falls by >= 20 %.
`benchmarks/bench_hidden_effects.py` prints the detection rate over magnitudes.
"""
import pytest

from sma_actuator.core.identification import DynamicData
from sma_actuator.workbench.engine import diagnose
from support.richsim import simulate

# effect, magnitude, excitation, noise [rad], rate [Hz], seed
STRONG = [
    ('none', 0.0, 'open', 0.002, 40, 11),
    ('none', 0.0, 'closed', 0.004, 25, 12),
    ('saturation', 1.0, 'open', 0.002, 50, 13),
    ('fast_dynamics', 1.2, 'open', 0.003, 100, 14),
    ('delay', 1.5, 'closed', 0.002, 40, 15),
    ('ambient_drift', 1.0, 'open', 0.002, 20, 17),
    ('stress_coupling', 1.0, 'open', 0.002, 30, 19),
    ('asymmetric_wires', 1.5, 'open', 0.002, 40, 20),
    ('sensor_nonlinearity', 1.5, 'open', 0.002, 40, 21),
    ('current_limit', 1.2, 'open', 0.002, 60, 23),
    ('fatigue_drift', 1.5, 'open', 0.002, 40, 22),
    ('fatigue_drift', 0.3, 'open', 0.002, 40, 290),
    ('convection', 1.5, 'open', 0.002, 40, 16),
]
WEAK = [
    ('phase_resistance', 1.0, 'open', 0.001, 40, 18),
]
DURATION_S = 480.0


def _data(effect, magnitude, excitation, noise, rate, seed):
    d = simulate(effect, magnitude=magnitude, excitation=excitation, duration_s=DURATION_S,
                 rate_hz=rate, noise_rad=noise, seed=seed)
    return DynamicData(d['time'], d['duty_a'], d['duty_b'], d['position'],
                       d.get('ambient_temperature'))


@pytest.mark.parametrize('effect,magnitude,excitation,noise,rate,seed', STRONG,
                         ids=[f'{c[0]}-M{c[1]}-{c[2]}-{c[4]}Hz' for c in STRONG])
def test_diagnose_names_the_hidden_effect(effect, magnitude, excitation, noise, rate, seed):
    data = _data(effect, magnitude, excitation, noise, rate, seed)
    # saturation is judged against a classical-PI base (the paper's eq. 5 model)
    diag = diagnose(data, kind='classical' if effect == 'saturation' else None)
    ranking = [(c['effect'], c['improvement'], c['significant']) for c in diag.candidates]
    if effect == 'none':
        assert diag.missing_effect is None, ranking
        assert not any(c['significant'] for c in diag.candidates), ranking
        return
    top = diag.candidates[0]
    assert top['effect'] == effect, ranking
    assert diag.missing_effect == effect, ranking
    assert top['improvement'] >= 0.40, ranking


@pytest.mark.parametrize('effect,magnitude,excitation,noise,rate,seed', WEAK,
                         ids=[f'{c[0]}-{c[2]}-{c[4]}Hz' for c in WEAK])
def test_diagnose_never_misattributes_a_weakly_visible_effect(effect, magnitude, excitation,
                                                              noise, rate, seed):
    diag = diagnose(_data(effect, magnitude, excitation, noise, rate, seed))
    ranking = [(c['effect'], c['improvement'], c['significant']) for c in diag.candidates]
    assert diag.missing_effect in (effect, None), ranking
    if diag.missing_effect == effect:
        assert diag.candidates[0]['effect'] == effect, ranking
        assert diag.candidates[0]['improvement'] >= 0.20, ranking
