"""Extreme design requests: bounded work, or a one-line refusal that says why.

A sampled-loop analysis needs about 240 rate / bandwidth samples (twelve of the slowest time constants at
the lowest damping accepted); the rule in :func:`control_design.loops.check_rate` caps that at 2.4e6 and
the rate at 1e5 Hz. The discrete responses are computed by doubling (:func:`power_sequence`), checked here
against a plain loop and against python-control.
"""

from __future__ import annotations

import math
import subprocess
import sys

import control
import numpy as np
import pytest

from control_design.decentralised import design_joint
from control_design.errors import SamplingRateError
from control_design.loops import MAX_RATE_HZ, MAX_RATE_PER_BANDWIDTH, JointPlant, check_rate
from control_design.responses import disturbance_rejection, power_sequence, step_response

WRIST = JointPlant(J_m=3.3e-5, B_m=7.1e-5, G=76.0, name="wrist")


def test_policy_constants_and_their_reason():
    # pinned by value: 240 rate / bandwidth samples <= 2.4e6, and a 15 s task at the top rate keeps 1.5e6 samples
    assert MAX_RATE_PER_BANDWIDTH == 1.0e4 and MAX_RATE_HZ == 1.0e5


@pytest.mark.parametrize("count", [1, 2, 3, 7, 8, 9, 1000, 1025])
def test_power_sequence_equals_the_plain_recursion(count):
    rng = np.random.default_rng(count)
    A = rng.normal(size=(4, 4))
    A /= 1.01 * np.max(np.abs(np.linalg.eigvals(A)))
    v = rng.normal(size=4)
    ref, x = np.empty((4, count)), v.copy()
    for k in range(count):
        ref[:, k] = x
        x = A @ x
    # doubling reorders the products: rounding only, a few ulp of the largest entry per doubling
    assert np.allclose(power_sequence(A, v, count), ref, rtol=0, atol=1e-13 * np.abs(ref).max())


def test_discrete_step_response_equals_python_control():
    loop = design_joint(WRIST, "pid", bandwidth=50.0, damping=0.7, rate_hz=1000.0)
    st = step_response(loop, discrete=True)
    A, B, C, D = loop.closed_loop_matrices(discrete=True)
    ref = control.step_response(control.ss(A, B[:, :1], C[[0, 2], :], D[[0, 2], :1], loop.period()), timepts=st.t)
    y = np.asarray(ref.outputs).reshape(2, -1)
    assert np.allclose(st.theta_m, y[0], rtol=0, atol=1e-12) and np.allclose(st.tau_m, y[1], rtol=0, atol=1e-12 * abs(y[1]).max())


def test_rate_bounds_are_refused_with_the_reason():
    check_rate(1.0, 1.0e4)  # exactly at the limit: accepted
    with pytest.raises(SamplingRateError, match=r"bandwidth: 1e-09 rad/s at a control rate of 1000 Hz needs about 2\.4e\+14 samples"):
        check_rate(1e-9, 1000.0)
    with pytest.raises(SamplingRateError, match=r"rate: 1e\+07 Hz is above the highest control rate simulated, 100000 Hz"):
        check_rate(50.0, 1e7)


def test_a_design_at_the_sample_limit_completes():
    # The worst case accepted: lowest damping, PID, rate / bandwidth = 1e4; about 1.2e6 samples per response.
    plant = JointPlant(J_m=1e-3, B_m=0.0, G=50.0, name="frictionless")
    loop = design_joint(plant, "pid", bandwidth=0.1, damping=0.05, rate_hz=1000.0)
    st = step_response(loop, discrete=True)
    rej = disturbance_rejection(loop, discrete=True)
    assert st.t.size > 1e6 and math.isfinite(st.settling_time) and rej.l1_gain_m > 0


@pytest.mark.parametrize("flags, message", [
    (["--bandwidth", "1e-9"], "bandwidth: 1e-09 rad/s at a control rate of 1000 Hz needs about"),
    (["--bandwidth", "1e-3"], "bandwidth: 0.001 rad/s at a control rate of 1000 Hz needs about"),
    (["--rate", "1e7"], "rate: 1e+07 Hz is above the highest control rate simulated"),
])
def test_cli_refuses_extreme_values_before_any_work(tmp_path, flags, message):
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", "workbench.cli", "design", "planar2r", *flags, "--out", str(out)],
                          capture_output=True, text=True, timeout=120)  # a guard against the old hang, not a timing test
    lines = [ln for ln in done.stderr.splitlines() if ln.strip() and not ln.startswith("manip: warning")]
    assert done.returncode == 2 and len(lines) == 1 and message in lines[0], done.stderr
    assert not out.exists()
