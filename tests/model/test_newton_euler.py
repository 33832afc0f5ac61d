"""Lagrange and Newton-Euler, two independent constructions, give the same torques and accelerations.

Evaluated with CasADi (no compilation) on seeded random states, with a
random payload and friction, for every built-in robot and both motor models.
Tolerance 1e-10 relative to the largest torque: the two formulations share
no code beyond the DH data, and agree to rounding (~1e-14) when both are right.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from model import InertiaConsistencyWarning, load_description
from model.dynamics import MOTOR_MODELS, build_functions, parameter_layout
from tests.support.references import random_payload_parameters
from tests.support.references import available_robots

RTOL = 1e-10


@pytest.fixture(scope="module", params=[(r, m) for r in available_robots() for m in MOTOR_MODELS],
                ids=lambda rm: f"{rm[0]}-{rm[1]}")
def model(request):
    name, motor_model = request.param
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        desc = load_description(name)
    return desc, build_functions(desc, motor_model)


def random_parameters(desc, rng):
    """A random payload (references.random_payload_parameters) and random friction."""
    p = random_payload_parameters(desc, rng)
    s = parameter_layout(desc).slices
    p[s["viscous_friction"]] = rng.uniform(0, 2e-3, desc.n)
    p[s["coulomb_friction_pos"]] = rng.uniform(0, 0.2, desc.n)
    p[s["coulomb_friction_neg"]] = -rng.uniform(0, 0.2, desc.n)
    return p


def test_rne_lagrange_equals_newton_euler(model):
    desc, f = model
    rng = np.random.default_rng(11)
    for _ in range(10):
        q, qd, qdd = rng.uniform(-2, 2, (3, desc.n))
        p = random_parameters(desc, rng)
        tau_ne = np.array(f.rne(q, qd, qdd, p)).ravel()
        tau_lag = np.array(f.rne_lagrange(q, qd, qdd, p)).ravel()
        np.testing.assert_allclose(tau_lag, tau_ne, rtol=0, atol=RTOL * max(1.0, np.abs(tau_ne).max()))


def test_accel_lagrange_equals_newton_euler_and_inverts_rne(model):
    desc, f = model
    rng = np.random.default_rng(12)
    for _ in range(10):
        q, qd, tau = rng.uniform(-2, 2, (3, desc.n))
        p = random_parameters(desc, rng)
        a_ne = np.array(f.accel(q, qd, tau, p)).ravel()
        a_lag = np.array(f.accel_lagrange(q, qd, tau, p)).ravel()
        scale = max(1.0, np.abs(a_ne).max())
        np.testing.assert_allclose(a_lag, a_ne, rtol=0, atol=RTOL * scale)
        back = np.array(f.rne(q, qd, a_ne, p)).ravel()
        np.testing.assert_allclose(back, tau, rtol=0, atol=RTOL * max(1.0, np.abs(back).max()) * 10)


@pytest.mark.parametrize("name", ["planar2r", "scara", "puma560"])
def test_full_and_reflected_motor_models_differ(name):
    """The comparison has teeth: on robots with motors beyond joint 1, the rotor coupling changes the torques."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        desc = load_description(name)
    full, reflected = build_functions(desc, "full"), build_functions(desc, "reflected")
    rng = np.random.default_rng(13)
    q, qd, qdd = rng.uniform(-2, 2, (3, desc.n))
    p = parameter_layout(desc).defaults
    tau_full = np.array(full.rne(q, qd, qdd, p)).ravel()
    tau_refl = np.array(reflected.rne(q, qd, qdd, p)).ravel()
    assert np.abs(tau_full - tau_refl).max() > 1e-6 * np.abs(tau_refl).max()
