"""Stick-slip Coulomb friction in the FMU: the Puma 560 through FMPy (Model Exchange with CVode, Co-Simulation
with the plant's fixed-step rule) against the test oracle of the same law (tests/support/stick_slip_oracle.py:
NumPy, events located by solve_ivp).

The arm rests at its rest pose with gravity held by a constant motor torque;
joint 1 (vertical axis) gets torque pulses above, below and across its static
limit, so it slips, sticks, is held and breaks loose again, and the other
joints, coupled to it, stick and slip too. Before the FMU had friction modes,
CVode stopped ("mxstep steps taken") on the sign switch at qd = 0.
"""

from __future__ import annotations

import warnings
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

from tests.support.stick_slip_oracle import coulomb_limits, simulate_stick_slip
from fmu.simulate import simulate_cs, simulate_me, step_input
from fmu.validate import TorqueProfile
from model import InertiaConsistencyWarning, load_robot

from tests.support.fmu_support import puma_fmu

N = 6
HOLD = 0.25
T_END = 2.0
STATES = [f"q[{i}]" for i in range(1, N + 1)] + [f"qd[{i}]" for i in range(1, N + 1)]
TAU = [f"tau_m[{i}]" for i in range(1, N + 1)]
DOCS_IMG = Path(__file__).resolve().parents[2] / "docs" / "img"


@lru_cache(maxsize=None)
def scenario():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        robot = load_robot("puma560")
    t = np.arange(0.0, T_END, HOLD)
    tau = np.tile(robot.gravload(robot.q_rest) / robot.gear_ratio, (t.size, 1))   # gravity held, motor side
    # joint 1's static limit is 0.395 / -0.435 N m (motor side): pulses across it, and one that it holds
    tau[:, 0] = [0.6, 0.0, 0.2, -0.7, -0.7, 0.1, 0.55, 0.0]
    profile = TorqueProfile(t, tau, T_END, np.zeros((t.size + 1, N)), "gravity held, pulses on joint 1")
    ref = simulate_stick_slip(robot, profile, rtol=1e-11, atol=1e-12, samples_per_hold=25)
    return robot, profile, ref


def _at(result, names, t_ref):
    """Samples at t_ref; the last sample at a time (Model Exchange repeats the time of an event)."""
    idx = [result.t.size - 1 - int(np.argmin(np.abs(result.t[::-1] - tr))) for tr in t_ref]
    assert np.max(np.abs(result.t[idx] - t_ref)) < 1e-9
    return result.stack(names)[idx]


def test_the_scenario_sticks_and_slips():
    robot, _, ref = scenario()
    stuck = ref.modes[:, 0] == 0
    assert stuck.sum() > 20 and (~stuck).sum() > 20 and len(ref.events) >= 3
    assert np.all(ref.X[stuck, N] == 0.0)
    tc_pos, tc_neg = coulomb_limits(robot)
    assert np.all((ref.F[stuck, 0] >= tc_neg[0] - 1e-9) & (ref.F[stuck, 0] <= tc_pos[0] + 1e-9))


@pytest.mark.parametrize("interface", [pytest.param("ModelExchange", marks=pytest.mark.slow), "CoSimulation"])
def test_puma_with_real_friction_matches_the_stick_slip_reference(interface, tmp_path):
    robot, profile, ref = scenario()
    table = step_input(TAU, profile.t_switch, profile.tau_m)
    if interface == "ModelExchange":
        res = simulate_me(puma_fmu(), T_END, 1e-3, inputs=table, outputs=STATES, relative_tolerance=1e-10)
        # CVode at rtol 1e-10 with root finding on the indicators (seen 2e-9 on the planar 2R): 1e-6 rad, rad/s
        tol = 1e-6
    else:
        res = simulate_cs(puma_fmu(), T_END, 1e-3, inputs=table, outputs=STATES)
        # RK4 at 1 ms, events located by bisection to 1e-15 s (seen 2e-11 on the planar 2R): 1e-8 rad, rad/s
        tol = 1e-8
    X = _at(res, STATES, ref.t)
    err = np.max(np.abs(X - ref.X), axis=0)
    print(interface, "max |x - x_ref| per state:", np.array2string(err, precision=2))
    assert err.max() < tol
    # the stuck intervals are exactly at rest in the FMU too
    stuck = ref.modes[:, 0] == 0
    assert np.all(X[stuck, N] == 0.0)

    if interface == "ModelExchange":
        _plot(ref, res, tmp_path)


def test_the_old_sign_law_would_miss_by_far_more_than_the_tolerance():
    """Negative control: qd-sign Coulomb friction without stick (``robot.accel``, the sliding law) integrated
    the same way leaves the stick-slip reference by orders of magnitude more than the tolerances above."""
    robot, profile, ref = scenario()
    # Fixed-step RK4 at 0.1 ms over the first two holds (an adaptive solver chatters without end on the
    # sign switch: that is the bug this law replaces), sampled at the hold ends.
    G = robot.gear_ratio
    x, h, t, X = np.concatenate([robot.q_rest, np.zeros(N)]), 1e-4, [], []
    for k in range(2):
        u = profile.tau_m[k]
        f = lambda xv, u=u: np.concatenate([xv[N:], robot.accel(xv[:N], xv[N:], G * u)])  # noqa: E731
        for _ in range(int(round(HOLD / h))):
            k1 = f(x)
            k2 = f(x + 0.5 * h * k1)
            k3 = f(x + 0.5 * h * k2)
            k4 = f(x + h * k3)
            x = x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        t.append((k + 1) * HOLD)
        X.append(x.copy())
    X = np.array(X)
    X_ref = np.array([ref.X[int(np.argmin(np.abs(ref.t - tk)))] for tk in t])
    assert np.max(np.abs(X - X_ref)) > 1e-4


def _plot(ref, res, folder: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    robot, *_ = scenario()
    tc_pos, tc_neg = coulomb_limits(robot)
    fig, (ax_v, ax_f) = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
    ax_v.plot(res.t, res["qd[1]"], color="tab:blue", lw=2.5, alpha=0.5, label="FMU, Model Exchange (CVode)")
    ax_v.plot(ref.t, ref.X[:, N], color="k", lw=0.8, ls="--", label="Python reference")
    ax_v.set_ylabel("qd[1] (rad/s)")
    ax_v.set_title("Puma 560, joint 1: stick-slip with Coulomb friction")
    ax_v.legend(loc="upper left", fontsize=8)
    ax_f.plot(ref.t, ref.F[:, 0], color="tab:red", label="friction torque (reference; holding while stuck)")
    ax_f.axhline(tc_pos[0], ls="--", color="grey", label="static limits Tc+ / Tc-")
    ax_f.axhline(tc_neg[0], ls="--", color="grey")
    ax_f.set_ylabel("friction (N m, joint side)")
    ax_f.set_xlabel("t (s)")
    ax_f.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    for target in (folder, DOCS_IMG):
        target.mkdir(parents=True, exist_ok=True)
        fig.savefig(target / "puma_stick_slip.png", dpi=90)
    plt.close(fig)
    assert (folder / "puma_stick_slip.png").stat().st_size > 10_000
