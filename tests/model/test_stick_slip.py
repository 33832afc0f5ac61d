"""The stick-slip law: the plant's fixed-step rule and the test oracle against closed forms and invariants.

The law lives in model/dynamics/stick_slip.py and is integrated by the plant's rule
(model/dynamics/c/plant_step.c: RK4 sub-steps, events located by bisection); the test
oracle (tests/support/stick_slip_oracle.py) writes it again in NumPy and locates the
events with solve_ivp. Both are checked here against what no one here wrote:

1. One joint about a vertical axis (no gravity torque, constant inertia B, no
   viscous friction) under a piecewise-constant torque: every phase has a
   closed form (constant acceleration while sliding, rest while stuck), and the
   times of sticking and breaking loose follow from it (the stick event fires
   once the velocity has overshot zero by V_EPS = 1e-6 rad/s). RK4 is exact on
   these quadratics, so the rule meets the closed form to rounding and the event
   time to its bisection (1e-12 of a 1 ms sub-step); the oracle to its tolerance.
2. The planar 2R arm with Coulomb friction under a torque that makes joint 2
   stick and slip: while stuck, qd = 0 exactly and the holding torque stays
   within [Tc-, Tc+]; while sliding, the friction is the Coulomb torque of the
   velocity's sign. A plot of that joint's velocity and friction torque is
   written to the test's folder and to docs/img/stick_slip.png.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from model.dynamics.stick_slip import V_EPS
from tests.support.stick_slip_oracle import coulomb_limits, simulate_stick_slip
from fmu.validate import TorqueProfile
from model import InertiaConsistencyWarning, Robot
from model.description import description_from_dict

DOCS_IMG = Path(__file__).resolve().parents[2] / "docs" / "img"


def one_joint() -> Robot:
    link = {"joint": "revolute", "a": 0.5, "alpha": 0.0, "d": 0.0, "theta": 0.0, "mass": 2.0,
            "com": [-0.25, 0.0, 0.0], "inertia": [0.01, 0.05, 0.05, 0.0, 0.0, 0.0], "motor_inertia": 1e-4,
            "gear_ratio": 50.0, "viscous_friction": 0.0, "coulomb_friction": [0.02, -0.03]}
    return Robot(description_from_dict({"name": "one_joint", "links": [link]}))


def profile(t_switch, tau_m, t_end) -> TorqueProfile:
    tau_m = np.asarray(tau_m, dtype=float)
    return TorqueProfile(np.asarray(t_switch, dtype=float), tau_m, float(t_end),
                         np.zeros((len(t_switch) + 1, tau_m.shape[1])), "test profile")


def _closed_form_one_joint():
    """B, the closed form (q, qd, friction) of the one-joint scenario and its stick time."""
    B = 0.05 + 2.0 * 0.25 ** 2 + 1e-4 * 50.0 ** 2          # izz + m r^2 + Jm G^2 = 0.425 kg m^2
    a1, a2, a4 = (2.0 - 1.0) / B, -1.0 / B, (-2.5 + 1.5) / B
    v1 = a1 * 0.5
    t_stick = 0.5 + v1 / -a2
    q_stick = a1 * 0.5 ** 2 / 2 + v1 * (t_stick - 0.5) + a2 * (t_stick - 0.5) ** 2 / 2

    def closed_form(t: float) -> tuple[float, float, float]:
        if t <= 0.5:
            return a1 * t ** 2 / 2, a1 * t, 1.0
        if t <= t_stick:
            s = t - 0.5
            return a1 * 0.5 ** 2 / 2 + v1 * s + a2 * s ** 2 / 2, v1 + a2 * s, 1.0
        if t <= 2.0:
            return q_stick, 0.0, 0.0 if t <= 1.5 else -1.25   # at a switching time: the value held before it
        s = t - 2.0
        return q_stick + a4 * s ** 2 / 2, a4 * s, -1.5

    return B, closed_form, t_stick, a2


ONE_JOINT_PROFILE = ([0.0, 0.5, 1.5, 2.0], [[0.04], [0.0], [-0.025], [-0.05]], 3.0)


def test_the_plants_rule_matches_the_closed_form_through_slip_stick_hold_and_break():
    """The rule every engine runs, at 1 ms sub-steps and 10 ms holds: the closed form to 1e-12 (rad, rad/s; RK4 is
    exact on quadratics, the stick event is bisected to 1e-12 of a 1 ms sub-step and overshoots by V_EPS / |a| = 4e-7 s, so the
    velocity is off the closed form by at most V_EPS = 1e-6 around it: those samples are compared to V_EPS)."""
    from model.compiled_plant import compiled_plant

    robot = one_joint()
    B, closed_form, t_stick, a2 = _closed_form_one_joint()
    t_switch, tau, t_end = ONE_JOINT_PROFILE
    run = compiled_plant(robot).run(robot.parameters.vector)
    t = np.arange(0, 301) * 0.01
    run.start(np.zeros(2), tau[0])
    X = [run.x.copy()]
    for k in range(300):
        held = tau[int(np.searchsorted(t_switch, t[k] + 1e-12, side="right")) - 1]
        assert run.advance(held, 0.01, 10)
        X.append(run.x.copy())
    X = np.array(X)
    expected = np.array([closed_form(tk) for tk in t])
    near = np.abs(t - t_stick) < 0.011
    assert np.max(np.abs(X[:, 0] - expected[:, 0])) < 1e-12
    assert np.max(np.abs(X[~near, 1] - expected[~near, 1])) < 1e-12
    assert np.max(np.abs(X[near, 1] - expected[near, 1])) <= V_EPS
    stuck = (t > t_stick + 1e-3) & (t <= 2.0)
    assert np.all(X[stuck, 1] == 0.0) and np.all(X[(t > 2.0), 1] < 0)


def test_the_oracle_matches_the_closed_form_through_slip_stick_hold_and_break():
    robot = one_joint()
    B, closed_form, t_stick, a2 = _closed_form_one_joint()
    assert robot.inertia([0.0])[0, 0] == pytest.approx(B, rel=1e-12)
    tc_pos, tc_neg = coulomb_limits(robot)
    assert (tc_pos[0], tc_neg[0]) == (1.0, -1.5)           # |G| x motor side
    # joint torques G tau_m: 2.0 (slides), 0 (decelerates, sticks at t = 1), -1.25 (held), -2.5 (breaks loose)
    res = simulate_stick_slip(robot, profile(*ONE_JOINT_PROFILE))

    expected = np.array([closed_form(t) for t in res.t])
    # DOP853 at rtol 1e-10 on polynomials of degree 2: errors at rounding level; 1e-9 leaves a wide margin
    assert np.max(np.abs(res.X[:, 0] - expected[:, 0])) < 1e-9
    assert np.max(np.abs(res.X[:, 1] - expected[:, 1])) < 1e-9
    assert np.max(np.abs(res.F[:, 0] - expected[:, 2])) < 1e-9
    # the event fires when qd has overshot zero by V_EPS: V_EPS / |a2| after the closed-form stop
    assert t_stick == pytest.approx(1.0)
    assert res.events[0] == pytest.approx(t_stick + V_EPS / -a2, abs=1e-9)
    stuck = (res.t > t_stick + 1e-9) & (res.t <= 2.0)
    assert np.all(res.X[stuck, 1] == 0.0) and np.all(res.modes[stuck, 0] == 0)


def test_planar2r_joint_sticks_and_slips_within_the_friction_limits(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from model.description import BUILTIN_DIR
    from model.loading import load_description

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        text = (BUILTIN_DIR / "planar2r.toml").read_text().replace(
            "viscous_friction = 0.01\n", "viscous_friction = 0.01\ncoulomb_friction = [0.6, -0.6]\n")
        toml = tmp_path / "planar2r_coulomb.toml"
        toml.write_text(text)
        robot = Robot(load_description(toml))
    tc_pos, tc_neg = coulomb_limits(robot)
    # hanging arm; motor 2 pushes one way then the other, weaker than its friction in between
    t = np.arange(0.0, 2.0, 0.25)
    tau = np.zeros((t.size, 2))
    tau[:, 1] = [1.0, 0.0, 0.3, -1.0, -1.0, 0.2, 0.9, 0.0]
    tau[:, 0] = 0.0
    res = simulate_stick_slip(robot, profile(t, tau, 2.0), samples_per_hold=50)
    qd2, f2, m2 = res.X[:, 3], res.F[:, 1], res.modes[:, 1]
    visc = robot.gear_ratio[1] ** 2 * 0.01 * qd2
    stuck, sliding = m2 == 0, m2 != 0
    assert stuck.sum() > 10 and sliding.sum() > 10 and len(res.events) >= 2
    assert np.all(qd2[stuck] == 0.0)
    assert np.all((f2[stuck] >= tc_neg[1] - 1e-9) & (f2[stuck] <= tc_pos[1] + 1e-9))
    # sliding: Coulomb of the sign of the velocity (plus viscous), never against it
    moving = sliding & (np.abs(qd2) > 1e-9)
    coulomb = np.where(qd2 > 0, tc_pos[1], tc_neg[1])
    assert np.allclose(f2[moving], coulomb[moving] + visc[moving], rtol=0, atol=1e-9)

    fig, (ax_v, ax_f) = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
    ax_v.plot(res.t, qd2, color="tab:blue")
    ax_v.set_ylabel("qd[2] (rad/s)")
    ax_v.set_title("planar 2R, joint 2: stick-slip with Coulomb friction (reference integrator)")
    ax_f.plot(res.t, f2, color="tab:red", label="friction torque (Coulomb + viscous; holding while stuck)")
    ax_f.axhline(tc_pos[1], ls="--", color="grey", label="Tc+ / Tc-")
    ax_f.axhline(tc_neg[1], ls="--", color="grey")
    ax_f.set_ylabel("friction (N m, joint side)")
    ax_f.set_xlabel("t (s)")
    ax_f.legend(loc="lower left")
    for ax in (ax_v, ax_f):
        for te in res.events:
            ax.axvline(te, color="k", lw=0.3, alpha=0.4)
    fig.tight_layout()
    for folder in (tmp_path, DOCS_IMG):
        folder.mkdir(parents=True, exist_ok=True)
        fig.savefig(folder / "stick_slip.png", dpi=90)
    plt.close(fig)
    assert (tmp_path / "stick_slip.png").stat().st_size > 10_000
