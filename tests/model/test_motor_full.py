"""The "full" motor model against the closed forms of the planar two-link arm with rotors.

Seed 000 ("Dinamica del Manipolatore planare a due bracci", after Siciliano et
al. 2009, Sec. 7.3.2) derives B(q), C(q, qd) and g(q) of this arm; written here
with its typos corrected (see docs/seed-errata.md, "Dynamics (seed 000)"):

    b11 = I1 + m1 l1^2 + kr1^2 Im1 + I2 + m2 (a1^2 + l2^2 + 2 a1 l2 c2) + Im2 + mm2 a1^2
    b12 = I2 + m2 (l2^2 + a1 l2 c2) + kr2 Im2
    b22 = I2 + m2 l2^2 + kr2^2 Im2            (the seed prints kr2 Im2)
    h = -m2 a1 l2 s2,   C = [[h qd2, h (qd1 + qd2)], [-h qd1, 0]]
    g1 = (m1 l1 + mm2 a1 + m2 a1) g c1 + m2 l2 g c12,   g2 = m2 l2 g c12

with the data of model/robots/planar2r.toml (gravity along -y, joints about z).
Tolerance 1e-12 relative: both sides are a handful of products of the same
doubles; any missing term is >= 1e-4 relative.
"""

from __future__ import annotations

import numpy as np
import pytest

from model import load_robot


@pytest.fixture(scope="module")
def robot():
    return load_robot("planar2r", motor_model="full")


def closed_form(robot, q, qd):
    l1, l2 = robot.description.links
    a1 = l1.a
    m1, m2 = l1.mass, l2.mass
    lc1, lc2 = l1.a + l1.com[0], l2.a + l2.com[0]  # COM distance from the joint axis (com is in the far-end frame)
    I1, I2 = l1.inertia[2], l2.inertia[2]
    kr1, kr2 = l1.gear_ratio, l2.gear_ratio
    Im1, Im2 = l1.motor_inertia, l2.motor_inertia
    mm2 = l2.rotor_mass
    g = -robot.description.gravity[1]
    c1, c2, s2, c12 = np.cos(q[0]), np.cos(q[1]), np.sin(q[1]), np.cos(q[0] + q[1])
    b11 = I1 + m1 * lc1**2 + kr1**2 * Im1 + I2 + m2 * (a1**2 + lc2**2 + 2 * a1 * lc2 * c2) + Im2 + mm2 * a1**2
    b12 = I2 + m2 * (lc2**2 + a1 * lc2 * c2) + kr2 * Im2
    b22 = I2 + m2 * lc2**2 + kr2**2 * Im2
    h = -m2 * a1 * lc2 * s2
    B = np.array([[b11, b12], [b12, b22]])
    C = np.array([[h * qd[1], h * (qd[0] + qd[1])], [-h * qd[0], 0.0]])
    gv = np.array([(m1 * lc1 + mm2 * a1 + m2 * a1) * g * c1 + m2 * lc2 * g * c12, m2 * lc2 * g * c12])
    return B, C, gv


def test_full_motor_model_matches_closed_form(robot):
    rng = np.random.default_rng(21)
    for _ in range(10):
        q, qd = rng.uniform(-np.pi, np.pi, (2, 2))
        B, C, g = closed_form(robot, q, qd)
        np.testing.assert_allclose(robot.inertia(q), B, rtol=1e-12, atol=1e-12 * np.abs(B).max())
        np.testing.assert_allclose(robot.coriolis(q, qd), C, rtol=0, atol=1e-12 * max(1.0, np.abs(B).max() * np.abs(qd).max()))
        np.testing.assert_allclose(robot.gravload(q), g, rtol=0, atol=1e-12 * np.abs(g).max())


def test_reflected_model_lacks_the_rotor_coupling():
    """The reflected model has kr^2 Im on the diagonal only: b12 differs by exactly kr2 Im2, b11 by Im2 (+ rotor mass)."""
    full = load_robot("planar2r", motor_model="full")
    refl = load_robot("planar2r", motor_model="reflected")
    q = np.array([0.3, -0.7])
    l2 = full.description.links[1]
    dB = full.inertia(q) - refl.inertia(q)
    expected = np.array([
        [l2.motor_inertia + l2.rotor_mass * full.description.links[0].a ** 2, l2.gear_ratio * l2.motor_inertia],
        [l2.gear_ratio * l2.motor_inertia, 0.0],
    ])
    np.testing.assert_allclose(dB, expected, rtol=0, atol=1e-12 * np.abs(full.inertia(q)).max())
