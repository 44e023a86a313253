"""The third suite's mechanisms are MuJoCo's (issue 61), checked against the physics they stand
for: an encoder disc that slips on its shaft at a hard stop keeps the kinetic energy its clamp
must take out, I w^2 / 2 = C slip (the shock's finite stiffness adds a little: within 25 %); a
link behind a gear with play, whose friction beats gravity's torque, rests on the side of the
play the move dragged it to, half the play behind its motor (within a tenth: the contact's give,
and a link the braking eased off the contact); a stage's scale heated through the machine's heat
capacities (an ODE integrated) trails the air as its network's transfer function says; quantised
readings are counts whose scatter is the stated one."""

import numpy as np
import pytest

from calibench.sim.arm_cmm import ArmSim
from calibench.sim.concealed import heat, noise, simulated
from calibench.sim.concealed.simulated import DISC_INERTIA_KG_M2, disc_slip, gear_play_angles


@pytest.mark.parametrize("speed", [1.0, 2.0, 3.0])
@pytest.mark.parametrize("clamp_nm", [0.02, 0.05, 0.2])
def test_adisc_slips_by_the_energy_its_clamp_takes_out(speed, clamp_nm):
    slip = disc_slip(speed, clamp_nm)
    energy = 0.5 * DISC_INERTIA_KG_M2 * speed**2 / clamp_nm
    assert energy <= slip <= 1.25 * energy, (slip, energy)


def test_a_link_held_by_friction_lags_its_motor_by_the_play(monkeypatch):
    monkeypatch.setattr(simulated, "FRICTION_SHARE", (1.5, 1.5))  # friction beats gravity
    sim = ArmSim("ur10")
    rng = np.random.default_rng(3)
    q = sim.random_postures(60, rng)
    q_link, truth = gear_play_angles(sim, q, rng)
    j = truth["params"]["joint"] - 1
    half = truth["params"]["play_urad"] / 2 * 1e-6
    off = (q_link - q)[1:, j]
    moved = np.sign(np.diff(q[:, j]))
    assert np.array_equal(np.delete(q_link, j, axis=1), np.delete(q, j, axis=1))
    assert np.mean(np.sign(off) == -moved) >= 0.95  # behind, as it was dragged
    assert np.all(np.abs(off) <= 1.1 * half) and np.median(np.abs(off)) >= 0.9 * half


def test_a_heated_scale_trails_a_ramp_of_the_air_by_its_network_s_mean_delay():
    # the integrated network against its transfer function: a steady ramp of the air is
    # followed at the ramp's slope, the mean delay behind (-H'(0)), and a step settles on it
    A, b = heat.network(1800.0, 300.0, 0.25, 0.05)
    t = np.arange(0.0, 8 * 3600.0, 3.0)
    ramp = 20.0 + 1e-4 * t  # 0.36 K per hour
    scale = heat.thin_temperature(t, ramp, A, b)
    late = t > 4 * 3600.0  # five base time constants in: the start's transient gone
    delay = (ramp[late] - scale[late]) / 1e-4
    assert np.ptp(delay) < 1.0, np.ptp(delay)  # steady
    assert abs(delay.mean() - heat.mean_delay_s(A, b)) < 1.0, delay.mean()
    step = heat.thin_temperature(t, np.where(t > 60, 21.0, 20.0), A, b)
    assert abs(step[-1] - 21.0) < 1e-6 and step.max() <= 21.0 + 1e-9


def test_quantised_readings_keep_the_stated_scatter_in_counts():
    rng, n = np.random.default_rng(0), 20000
    sigma, truth = 1e-3, rng.uniform(0, 1, n)
    scatter = noise.reading_noise("quantised", rng, (n,), sigma)
    read = noise.read("quantised", truth + scatter, sigma)
    counts = read / (noise.QUANTUM_SIGMAS * sigma)
    assert np.allclose(counts, np.round(counts))
    # a uniform count's 3 / sqrt(12) and the half sigma before it, in quadrature: sigma, within
    # three standard errors of a standard deviation of n readings, sqrt((kurtosis - 1) / 4 n)
    e = read - truth
    kurtosis = np.mean((e - e.mean()) ** 4) / np.var(e) ** 2
    assert abs(np.std(e) / sigma - 1.0) < 3 * np.sqrt((kurtosis - 1) / (4 * n))


@pytest.mark.parametrize("kind", ["gaussian", "t3", "drift", "outliers", "quantised"])
def test_the_true_noise_is_the_readings_rms(kind):
    # what a verdict is judged against: the RMS the readings truly scatter by, within three
    # standard errors of an RMS of 200000 readings (the outliers' own scatter: 5 %)
    rng, sigma, n = np.random.default_rng(1), 1e-3, 200000
    truth = rng.uniform(0, 1, n)
    e = noise.read(kind, truth + noise.reading_noise(kind, rng, (n,), sigma), sigma) - truth
    rms = float(np.sqrt(np.mean(e**2)))
    kurtosis = np.mean(e**4) / np.mean(e**2) ** 2
    assert abs(rms / noise.noise_rms(kind, sigma) - 1) < 3 * np.sqrt((kurtosis - 1) / (4 * n))
