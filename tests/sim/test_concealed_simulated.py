"""The third suite's mechanisms are MuJoCo's (issue 61), checked against the physics they stand
for: an encoder disc that slips on its shaft at a hard stop keeps the kinetic energy its clamp
must take out, I w^2 / 2 = C slip (the shock's finite stiffness adds a little: within 25 %); a
link behind a gear with play, whose friction beats gravity's torque, rests on the side of the
play the move dragged it to, half the play behind its motor (within a tenth: the contact's give,
and a link the braking eased off the contact)."""

import numpy as np
import pytest

from calibench.sim.arm_cmm import ArmSim
from calibench.sim.concealed import simulated
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
