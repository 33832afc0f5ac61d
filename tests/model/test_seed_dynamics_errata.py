"""Seed 000's dynamics errata (docs/seed-errata.md, "Dynamics (seed 000)"), proved on the model.

Seed 000 (`/work/shared/seeds/000_84a0d743b6efa744.txt`) derives the SCARA's
B(q), C(q, qd), g(q) by Lagrange ("Dinamica del Manipolatore planare a due
bracci", "Dinamica totale dello SCARA") and prints the recursive Newton-Euler
equations ("Equazioni ricorsive del moto dei manipolatori"). Each test below
writes out the seed's equation with the erratum corrected, checks it against
the model, and checks that the form the seed prints does not match (by more
than a stated amount). D1 (two-link b22) is proved in tests/model/test_motor_full.py.

Closed form of the SCARA (model/robots/scara.toml; z0 up, alpha2 = pi so
z1 = z0 = k and z2 = z3 = -k). The seed lumps quill and wrist into one body
"l3/l4" of mass m_l3 on the z3 axis, turning with theta4, and neglects motors 3
and 4. Our data keep them apart, so the same derivation gives, with
ci = cos q_i, l1 = a1 + c1x, l2 = a2 + c2x, l3 = a2 + c3x (COM distances from
the joint axes, COM x in the far-end frame), I_i = Izz_i, kr_i = G_i, Im_i = Jm_i:

    planar part (seed, D1 corrected):
        b11' = I1 + m1 l1^2 + kr1^2 Im1 + I2 + m2 (a1^2 + l2^2 + 2 a1 l2 c2) + Im2 + mm2 a1^2
        b12' = I2 + m2 (l2^2 + a1 l2 c2) + kr2 Im2                  (D2: the seed prints kr2^2 Im2)
        b22' = I2 + m2 l2^2 + kr2^2 Im2
    wrist = the seed's last body (m_l3 -> m4, I_l4 -> I4; D5 corrected):
        b11'' = m4 (a1^2 + a2^2 + 2 a1 a2 c2) + I4,  b12'' = m4 (a2^2 + a1 a2 c2) + I4,
        b22'' = m4 a2^2 + I4,  b33'' = m4,  b44'' = I4,  b14'' = b24'' = -I4  (the seed: +I4)
    quill (a second "link 2": J_v like J_v^l2 with l2 -> l3 plus column 3 = -k, J_w row [1 1 0 0]):
        b11''' = m3 (a1^2 + l3^2 + 2 a1 l3 c2) + I3,  b12''' = m3 (l3^2 + a1 l3 c2) + I3,
        b22''' = m3 l3^2 + I3,  b33''' = m3
    rotors 3, 4 ("full" only; the seed neglects them), derived as the seed's rotor 2:
        w_m3 = (qd1 + qd2 - kr3 qd3) k,  w_m4 = (qd1 + qd2 - kr4 qd4) k, so
        b11, b12, b22 += Im3 + Im4,  b13 = b23 = -kr3 Im3,  b14, b24 += -kr4 Im4,
        b33 += kr3^2 Im3,  b44 += kr4^2 Im4
    "reflected": the rotors give only kr_i^2 Im_i on the diagonal (no Im2, no kr2 Im2, no rotor 3/4 coupling).

With c3x = 0 and the quill turning with the wrist, quill + wrist collapse to the
seed's m_l3 = m3 + m4, I_l4 = I3 + I4. B depends on q2 only, so (seed, with k
extended to the quill) C = [[k qd2, k (qd1 + qd2), 0, 0], [-k qd1, 0, 0, 0], 0, 0],
k = -(m2 a1 l2 + m3 a1 l3 + m4 a1 a2) s2, and g = [0, 0, -(m3 + m4) g, 0] (D4).

Tolerances: closed form vs model 1e-12 relative to the largest entry (both
sides are a few dozen products of the same doubles; observed ~1e-15); the
printed forms miss by >= 1e-3 kg m^2 (2 I4) up to 127 N, 9 orders above that.
Finite differences have their own tolerances, stated where used. Randomness is
seeded.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from model import InertiaConsistencyWarning, load_robot

pytestmark = pytest.mark.filterwarnings("ignore::model.description.InertiaConsistencyWarning")

RTOL = 1e-12


def _load(name, motor_model):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return load_robot(name, motor_model=motor_model)


@pytest.fixture(scope="module")
def scara_full():
    return _load("scara", "full")


@pytest.fixture(scope="module")
def scara_reflected():
    return _load("scara", "reflected")


@pytest.fixture(scope="module")
def spherical():
    return _load("spherical", "reflected")


# ----------------------------------------------------------------- SCARA Lagrange closed form
def scara_symbols(robot):
    """The seed's symbols, read from scara.toml; asserts the structure the closed form relies on."""
    L1, L2, L3, L4 = robot.description.links
    for lk in (L1, L2, L3, L4):
        assert lk.com[1] == 0.0 and lk.inertia[3:] == (0.0, 0.0, 0.0)
    assert L4.com[0] == 0.0  # wrist COM on the z3 axis, as the seed assumes
    assert L3.rotor_mass == L4.rotor_mass == 0.0
    assert robot.description.gravity[:2] == (0.0, 0.0)
    return dict(
        a1=L1.a, a2=L2.a,
        l1=L1.a + L1.com[0], l2=L2.a + L2.com[0], l3=L2.a + L3.com[0],
        m1=L1.mass, m2=L2.mass, m3=L3.mass, m4=L4.mass,
        I1=L1.inertia[2], I2=L2.inertia[2], I3=L3.inertia[2], I4=L4.inertia[2],
        kr1=L1.gear_ratio, kr2=L2.gear_ratio, kr3=L3.gear_ratio, kr4=L4.gear_ratio,
        Im1=L1.motor_inertia, Im2=L2.motor_inertia, Im3=L3.motor_inertia, Im4=L4.motor_inertia,
        mm2=L2.rotor_mass, g=-robot.description.gravity[2],
    )


def scara_B(s, q, motor_model, *, printed=()):
    """Corrected closed-form B(q); ``printed`` swaps in the seed's printed b12 ("D2") or b14/b24 sign ("D5")."""
    c2 = np.cos(q[1])
    a1, a2, l1, l2, l3 = s["a1"], s["a2"], s["l1"], s["l2"], s["l3"]
    m1, m2, m3, m4 = s["m1"], s["m2"], s["m3"], s["m4"]
    I1, I2, I3, I4 = s["I1"], s["I2"], s["I3"], s["I4"]
    kr1, kr2, kr3, kr4 = s["kr1"], s["kr2"], s["kr3"], s["kr4"]
    Im1, Im2, Im3, Im4 = s["Im1"], s["Im2"], s["Im3"], s["Im4"]
    full = motor_model == "full"
    # planar two-link part, with its rotors
    b11 = I1 + m1 * l1**2 + kr1**2 * Im1 + I2 + m2 * (a1**2 + l2**2 + 2 * a1 * l2 * c2)
    b12 = I2 + m2 * (l2**2 + a1 * l2 * c2)
    b22 = I2 + m2 * l2**2 + kr2**2 * Im2
    if full:
        b11 += Im2 + s["mm2"] * a1**2
        b12 += kr2**2 * Im2 if "D2" in printed else kr2 * Im2
    elif "D2" in printed:
        b12 += kr2**2 * Im2
    # quill
    b11 += m3 * (a1**2 + l3**2 + 2 * a1 * l3 * c2) + I3
    b12 += m3 * (l3**2 + a1 * l3 * c2) + I3
    b22 += m3 * l3**2 + I3
    # wrist = the seed's B''
    b11 += m4 * (a1**2 + a2**2 + 2 * a1 * a2 * c2) + I4
    b12 += m4 * (a2**2 + a1 * a2 * c2) + I4
    b22 += m4 * a2**2 + I4
    b14 = b24 = I4 if "D5" in printed else -I4
    b33 = m3 + m4 + kr3**2 * Im3
    b44 = I4 + kr4**2 * Im4
    b13 = b23 = 0.0
    if full:  # rotors 3 and 4, neglected by the seed
        b11 += Im3 + Im4
        b12 += Im3 + Im4
        b22 += Im3 + Im4
        b13 = b23 = -kr3 * Im3
        b14 += -kr4 * Im4
        b24 += -kr4 * Im4
    return np.array([
        [b11, b12, b13, b14],
        [b12, b22, b23, b24],
        [b13, b23, b33, 0.0],
        [b14, b24, 0.0, b44],
    ])


def scara_C(s, q, qd):
    k = -(s["m2"] * s["a1"] * s["l2"] + s["m3"] * s["a1"] * s["l3"] + s["m4"] * s["a1"] * s["a2"]) * np.sin(q[1])
    C = np.zeros((4, 4))
    C[0, 0], C[0, 1], C[1, 0] = k * qd[1], k * (qd[0] + qd[1]), -k * qd[0]
    return C


def scara_g(s, *, printed=()):
    g3 = (s["m3"] + s["m4"]) * s["g"]
    return np.array([0.0, 0.0, g3 if "D4" in printed else -g3, 0.0])


def scara_tau(s, q, qd, qdd, motor_model, *, printed=()):
    """The seed's tau_1..tau_4 (end of "Dinamica totale dello SCARA"), corrected unless ``printed``."""
    return scara_B(s, q, motor_model, printed=printed) @ qdd + scara_C(s, q, qd) @ qd + scara_g(s, printed=printed)


def random_scara_states(rng, count):
    """q in the joint limits; qd in [-2, 2]; qdd with |qdd_i| in [0.5, 2] so every coefficient shows."""
    q = np.column_stack([rng.uniform(-np.pi, np.pi, count), rng.uniform(-np.pi, np.pi, count),
                         rng.uniform(0.0, 3.5, count), rng.uniform(-np.pi, np.pi, count)])
    qd = rng.uniform(-2.0, 2.0, (count, 4))
    qdd = rng.uniform(0.5, 2.0, (count, 4)) * rng.choice([-1.0, 1.0], (count, 4))
    return q, qd, qdd


@pytest.mark.parametrize("motor_model", ["full", "reflected"])
def test_scara_closed_form_inertia_matches_model(motor_model, scara_full, scara_reflected):
    """B, C, g of the corrected closed form (D2, D4, D5 applied) equal the model's."""
    robot = scara_full if motor_model == "full" else scara_reflected
    s = scara_symbols(robot)
    rng = np.random.default_rng(2000)
    for q, qd, _ in zip(*random_scara_states(rng, 10)):
        B = robot.inertia(q)
        scale = np.abs(B).max()
        np.testing.assert_allclose(B, scara_B(s, q, motor_model), rtol=0, atol=RTOL * scale)
        np.testing.assert_allclose(robot.coriolis(q, qd), scara_C(s, q, qd), rtol=0, atol=RTOL * scale * 2.0)
        np.testing.assert_allclose(robot.gravload(q), scara_g(s), rtol=0, atol=RTOL * 100.0)


def test_d2_printed_b12_fits_neither_motor_model(scara_full, scara_reflected):
    """D2: the seed's SCARA b12 carries kr2^2 Im2; the rotor coupling is kr2 Im2 (full model).

    The printed b12 misses the full model by (kr2^2 - kr2) Im2 = 2.303 kg m^2 and the
    reflected one (no coupling term at all) by kr2^2 Im2 = 2.325 kg m^2: assert > 2 kg m^2.
    """
    s = scara_symbols(scara_full)
    assert (s["kr2"] ** 2 - s["kr2"]) * s["Im2"] == pytest.approx(2.303, abs=1e-3)
    rng = np.random.default_rng(2002)
    for q in rng.uniform(-np.pi, np.pi, (10, 4)):
        q[2] = 1.0
        for robot, mm in ((scara_full, "full"), (scara_reflected, "reflected")):
            B = robot.inertia(q)
            assert B[0, 1] == pytest.approx(scara_B(s, q, mm)[0, 1], rel=0, abs=RTOL * np.abs(B).max())
            assert abs(scara_B(s, q, "full", printed=("D2",))[0, 1] - B[0, 1]) > 2.0
        # the SCARA section's b22 (kr2^2 Im2) is right: the error is in b12 only
        assert scara_full.inertia(q)[1, 1] == pytest.approx(scara_B(s, q, "full")[1, 1], rel=RTOL)


def test_d5_printed_wrist_coupling_has_the_wrong_sign(scara_full, scara_reflected):
    """D5: b14 = b24 = -I_l4 (wrist axis z3 = -k); the seed's +I_l4 misses by 2 I4 = 1e-3 kg m^2.

    Reflected model (no rotor coupling, the seed's assumption): exactly -I4. Full model:
    -I4 - kr4 Im4, the rotor-4 coupling the seed neglects, same sign.
    """
    s = scara_symbols(scara_reflected)
    rng = np.random.default_rng(2005)
    for q in rng.uniform(-np.pi, np.pi, (10, 4)):
        q[2] = 1.0
        B = scara_reflected.inertia(q)
        atol = RTOL * np.abs(B).max()
        np.testing.assert_allclose(B[[0, 1], 3], [-s["I4"], -s["I4"]], rtol=0, atol=atol)
        assert np.all(np.abs(B[[0, 1], 3] - s["I4"]) > 0.9e-3)  # the printed +I4
        Bf = scara_full.inertia(q)
        np.testing.assert_allclose(Bf[[0, 1], 3], -(s["I4"] + s["kr4"] * s["Im4"]) * np.ones(2), rtol=0, atol=atol)


@pytest.mark.parametrize("motor_model", ["full", "reflected"])
def test_scara_equations_of_motion(motor_model, scara_full, scara_reflected):
    """The seed's tau_1..tau_4, corrected, equal rne (friction removed); each printed erratum breaks them.

    Printed D2 shifts tau1 by (kr2^2 - kr2) Im2 qdd2 and tau2 by the same with qdd1 (full) or
    kr2^2 Im2 qdd (reflected): >= 1.15 N m with |qdd| >= 0.5, asserted > 1 N m. Printed D4 shifts
    tau3 by 2 (m3 + m4) g = 127.5 N, asserted > 100 N. Printed D5 shifts tau1, tau2 by 2 I4 qdd4
    and tau4 by 2 I4 (qdd1 + qdd2): asserted > 0.9e-3 * |qdd| (the sums are checked only where
    |qdd1 + qdd2| >= 0.5).
    """
    robot = scara_full if motor_model == "full" else scara_reflected
    s = scara_symbols(robot)
    rng = np.random.default_rng(2010)
    for q, qd, qdd in zip(*random_scara_states(rng, 10)):
        tau = robot.rne(q, qd, qdd) - robot.friction(qd)
        atol = RTOL * max(1.0, np.abs(tau).max()) * 10.0  # rne sums ~10 terms of size |tau|
        np.testing.assert_allclose(scara_tau(s, q, qd, qdd, motor_model), tau, rtol=0, atol=atol)
        d2 = np.abs(scara_tau(s, q, qd, qdd, motor_model, printed=("D2",)) - tau)
        assert d2[0] > 1.0 and d2[1] > 1.0
        d4 = np.abs(scara_tau(s, q, qd, qdd, motor_model, printed=("D4",)) - tau)
        assert d4[2] > 100.0
        d5 = np.abs(scara_tau(s, q, qd, qdd, motor_model, printed=("D5",)) - tau)
        assert d5[0] > 0.9e-3 * abs(qdd[3]) and d5[1] > 0.9e-3 * abs(qdd[3])
        if abs(qdd[0] + qdd[1]) >= 0.5:
            assert d5[3] > 0.9e-3 * 0.5


def _link4_com(robot, q):
    T = robot.fkine_all(q)[4]
    return T[:3, 3] + T[:3, :3] @ np.array(robot.description.links[3].com)


def test_d3_link4_com_jacobian(scara_reflected):
    """D3: J_v^l4 row 2 is [a1 c1 + a2 c12, a2 c12, 0, 0] (the seed: a1 c1 - a2 c12), and its
    (3,3) element is -1 (the seed: +1; z2 = -k); D5's cause: J_w^l4 last row is [1 1 0 -1].

    Model side: central differences (h = 1e-6) of the link-4 COM position from fkine_all and the
    COM offset, and of R_04 (w = vee(dR R^T)). Error: truncation h^2/6 |p'''| ~ 1e-12 m, rounding
    ~ eps |p| / h ~ 1e-9 m: tolerance 1e-8. Printed (2,1) misses by 2 a2 |c12| >= 0.8 (q drawn
    with |c12| >= 0.2), asserted > 0.5; printed J_v (3,3) and J_w (3,4) miss by 2, asserted > 1.
    """
    robot = scara_reflected
    s = scara_symbols(robot)
    a1, a2 = s["a1"], s["a2"]
    rng = np.random.default_rng(2003)
    h = 1e-6
    checked = 0
    while checked < 10:
        q = np.array([*rng.uniform(-np.pi, np.pi, 2), rng.uniform(0.2, 3.3), rng.uniform(-np.pi, np.pi)])
        c1, s1, c12, s12 = np.cos(q[0]), np.sin(q[0]), np.cos(q[0] + q[1]), np.sin(q[0] + q[1])
        if abs(c12) < 0.2:
            continue
        checked += 1
        Jv = np.zeros((3, 4))
        Jw = np.zeros((3, 4))
        R = robot.fkine_all(q)[4][:3, :3]
        for j in range(4):
            e = np.zeros(4)
            e[j] = h
            Jv[:, j] = (_link4_com(robot, q + e) - _link4_com(robot, q - e)) / (2 * h)
            S = (robot.fkine_all(q + e)[4][:3, :3] - robot.fkine_all(q - e)[4][:3, :3]) / (2 * h) @ R.T
            Jw[:, j] = [S[2, 1], S[0, 2], S[1, 0]]
        Jv_seed = np.array([
            [-a1 * s1 - a2 * s12, -a2 * s12, 0.0, 0.0],
            [a1 * c1 + a2 * c12, a2 * c12, 0.0, 0.0],
            [0.0, 0.0, -1.0, 0.0],
        ])
        Jw_seed = np.array([[0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [1.0, 1.0, 0.0, -1.0]])
        np.testing.assert_allclose(Jv, Jv_seed, rtol=0, atol=1e-8)
        np.testing.assert_allclose(Jw, Jw_seed, rtol=0, atol=1e-8)
        assert abs((a1 * c1 - a2 * c12) - Jv[1, 0]) > 0.5  # printed (2,1)
        assert abs(1.0 - Jv[2, 2]) > 1.0  # printed (3,3)
        assert abs(1.0 - Jw[2, 3]) > 1.0  # printed J_w^l4 (3,4)


def test_d4_gravity_on_the_quill(scara_full, scara_reflected):
    """D4: g3 = -(m3 + m4) g = -63.765 N (z2 = -k: d3 lowers the quill), not the seed's +m_l3 g.

    g(q) is the torque that holds the arm (B qdd + C qd + g = tau, the seed's own form), so the
    quill actuator pulls up with 63.765 N. Cross-check: dU/dd3 by central difference of
    U = -sum m_i gravity . p_Ci from fkine_all (U is linear in d3: only rounding, ~eps U / h
    ~ 1e-8 N with h = 1e-6; tolerance 1e-6 N). The printed +63.765 N misses by 127.5 N (> 100).
    """
    s = scara_symbols(scara_full)
    assert -(s["m3"] + s["m4"]) * s["g"] == pytest.approx(-63.765, abs=1e-9)
    gravity = np.array(scara_full.description.gravity)

    def U(q):
        frames = scara_full.fkine_all(q)
        return -sum(lk.mass * gravity @ (T[:3, 3] + T[:3, :3] @ np.array(lk.com))
                    for lk, T in zip(scara_full.description.links, frames[1:]))

    rng = np.random.default_rng(2004)
    h = 1e-6
    for q in rng.uniform(-np.pi, np.pi, (10, 4)):
        q[2] = rng.uniform(0.1, 3.4)
        for robot in (scara_full, scara_reflected):
            g = robot.gravload(q)
            np.testing.assert_allclose(g, [0.0, 0.0, -63.765, 0.0], rtol=0, atol=1e-10)
            assert abs(scara_g(s, printed=("D4",))[2] - g[2]) > 100.0
        e = np.array([0.0, 0.0, h, 0.0])
        assert (U(q + e) - U(q - e)) / (2 * h) == pytest.approx(-63.765, abs=1e-6)


# ---------------------------------------------------------------- Newton-Euler (seed's link-frame form)
def _rot(alpha, theta):
    """R_{i}^{i-1} = Rz(theta) Rx(alpha): frame i in frame i-1 (the seed's R_{i-1}^i is its transpose)."""
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array([[ct, -st * ca, st * sa], [st, ct * ca, -ct * sa], [0.0, sa, ca]])


def seed_newton_euler(desc, q, qd, qdd, gravity, printed=()):
    """The seed's recursive Newton-Euler in link frames ("Dunque, le equazioni diventano"), corrected.

    Every vector of link i in frame-i axes (the seed's R_0^i x); z0 = [0 0 1] is the local z of
    frame i-1. ``printed`` swaps in the seed's printed element:
      "D8":  a_i = wd x s + w x (w x s) + v_i          (corrected: + vd_i)
      "D9":  n_i = ... + (p* x s) x F_i + ...           (corrected: (p* + s) x F_i)
      "D10": prismatic vd_i has 2 (R_0^i wd_i) x (R_0^i z0 qd_i)   (corrected: 2 w_i x (R_{i-1}^i z0 qd_i))
    Initial conditions w0 = wd0 = v0 = 0, vd0 = -gravity. No friction (b_i = 0).
    Returns (tau, dict of the forward quantities, frame-i axes, with R_0i, frame i in base).
    """
    n = desc.n
    z0 = np.array([0.0, 0.0, 1.0])
    w, wd, v, vd = np.zeros(3), np.zeros(3), np.zeros(3), -np.asarray(gravity, dtype=float)
    R0i = np.eye(3)
    out = {k: [] for k in ("R", "R0i", "p", "w", "wd", "v", "vd", "a")}
    for i, lk in enumerate(desc.links):
        theta = q[i] + lk.theta if lk.is_revolute else lk.theta
        d = lk.d if lk.is_revolute else q[i] + lk.d
        R = _rot(lk.alpha, theta)
        R0i = R0i @ R
        p = np.array([lk.a, d * np.sin(lk.alpha), d * np.cos(lk.alpha)])  # R_0^i p_i*
        if lk.is_revolute:
            w_new = R.T @ (w + z0 * qd[i])
            wd_new = R.T @ (wd + z0 * qdd[i] + np.cross(w, z0 * qd[i]))
            vd_new = np.cross(wd_new, p) + np.cross(w_new, np.cross(w_new, p)) + R.T @ vd
            v_new = R.T @ v + np.cross(w_new, p)
        else:
            w_new = R.T @ w
            wd_new = R.T @ wd
            if "D10" in printed:
                coriolis = 2 * np.cross(wd_new, R0i.T @ z0 * qd[i])
            else:
                coriolis = 2 * np.cross(w_new, R.T @ z0 * qd[i])
            vd_new = R.T @ (z0 * qdd[i] + vd) + np.cross(wd_new, p) + coriolis + np.cross(w_new, np.cross(w_new, p))
            v_new = R.T @ (v + z0 * qd[i]) + np.cross(w_new, p)
        w, wd, v, vd = w_new, wd_new, v_new, vd_new
        s = np.array(lk.com)
        a = np.cross(wd, s) + np.cross(w, np.cross(w, s)) + (v if "D8" in printed else vd)
        for key, val in (("R", R), ("R0i", R0i), ("p", p), ("w", w), ("wd", wd), ("v", v), ("vd", vd), ("a", a)):
            out[key].append(val)

    tau = np.zeros(n)
    f, nm, R_next = np.zeros(3), np.zeros(3), np.eye(3)  # f_{n+1} = n_{n+1} = 0: no load
    for i in reversed(range(n)):
        lk = desc.links[i]
        p, s, w, wd = out["p"][i], np.array(lk.com), out["w"][i], out["wd"][i]
        I = lk.inertia_matrix
        F = lk.mass * out["a"][i]
        N = I @ wd + np.cross(w, I @ w)
        moment_F = np.cross(np.cross(p, s), F) if "D9" in printed else np.cross(p + s, F)
        # R_{i+1}^i [R_0^{i+1} n_{i+1} + (R_0^{i+1} p_i*) x (R_0^{i+1} f_{i+1})] + ... + R_0^i N_i
        nm = R_next @ (nm + np.cross(R_next.T @ p, f)) + moment_F + N
        f = F + R_next @ f
        axis = out["R"][i].T @ z0  # R_{i-1}^i z0
        tau[i] = nm @ axis if lk.is_revolute else f @ axis
        R_next = out["R"][i]
    return tau, out


def rigid_body_rne(robot, q, qd, qdd):
    """The model's rne without friction and without the reflected rotor term G^2 Jm qdd."""
    G = np.array([lk.gear_ratio for lk in robot.description.links])
    Jm = np.array([lk.motor_inertia for lk in robot.description.links])
    return robot.rne(q, qd, qdd) - robot.friction(qd) - G**2 * Jm * qdd


def random_states(robot, rng, count):
    lo, hi = robot.qlim
    q = rng.uniform(np.maximum(lo, -np.pi), np.minimum(hi, np.pi), (count, robot.n))
    return q, rng.uniform(-2.0, 2.0, (count, robot.n)), rng.uniform(-2.0, 2.0, (count, robot.n))


@pytest.mark.parametrize("name", ["scara", "spherical"])
def test_seed_newton_euler_corrected_matches_rne(name, scara_reflected, spherical):
    """The seed's link-frame recursion, with D8, D9, D10 corrected, gives the model's torques.

    Tolerance 1e-10 relative to the largest torque, as in tests/model/test_newton_euler.py: two
    independent codes in doubles (observed ~1e-15).
    """
    robot = scara_reflected if name == "scara" else spherical
    rng = np.random.default_rng(2008)
    for q, qd, qdd in zip(*random_states(robot, rng, 10)):
        tau_model = rigid_body_rne(robot, q, qd, qdd)
        tau_seed, _ = seed_newton_euler(robot.description, q, qd, qdd, robot.description.gravity)
        np.testing.assert_allclose(tau_seed, tau_model, rtol=0, atol=1e-10 * np.abs(tau_model).max())


@pytest.mark.parametrize("name", ["scara", "spherical"])
def test_d8_com_acceleration_is_the_derivative_of_the_com_velocity(name, scara_reflected, spherical):
    """D8: a_i = wd x s + w x (w x s) + vd_i is the COM acceleration; the printed + v_i is not.

    Model side: second central difference, h = 2.5e-4 s, of the COM position from fkine_all along
    q(t) = q + qd t + qdd t^2 / 2 (no gravity). Error: truncation h^2 |p^(4)| / 12, observed
    <= 7e-6 m/s^2 at h = 1e-3, so <= 5e-7 here; rounding eps |p| / h^2 ~ 2e-8: tolerance 1e-5 m/s^2.
    The printed form misses by |vd_i - v_i| (|qd|, |qdd| up to 2; observed 1.3-8.8 m/s^2),
    asserted > 0.5 m/s^2 on the worst link of every state.
    """
    robot = scara_reflected if name == "scara" else spherical
    desc = robot.description
    rng = np.random.default_rng(2009)
    h = 2.5e-4

    def coms(q):
        return np.array([T[:3, 3] + T[:3, :3] @ np.array(lk.com) for lk, T in zip(desc.links, robot.fkine_all(q)[1:])])

    for q, qd, qdd in zip(*random_states(robot, rng, 5)):
        path = lambda t: q + qd * t + 0.5 * qdd * t**2  # noqa: E731
        fd = (coms(path(h)) - 2 * coms(path(0.0)) + coms(path(-h))) / h**2
        _, out = seed_newton_euler(desc, q, qd, qdd, np.zeros(3))
        a = np.array([R @ ai for R, ai in zip(out["R0i"], out["a"])])
        np.testing.assert_allclose(a, fd, rtol=0, atol=1e-5)
        _, out_p = seed_newton_euler(desc, q, qd, qdd, np.zeros(3), printed=("D8",))
        a_p = np.array([R @ ai for R, ai in zip(out_p["R0i"], out_p["a"])])
        assert np.abs(a_p - fd).max() > 0.5


@pytest.mark.parametrize(("erratum", "name", "min_miss"), [
    ("D8", "scara", 100.0),      # gravity (in vd0) drops out of F: tau3 alone loses (m3 + m4) g = 63.8 N
    ("D8", "spherical", 1.0),
    ("D9", "scara", 10.0),
    ("D9", "spherical", 1.0),
    ("D10", "spherical", 0.1),
])
def test_printed_newton_euler_elements_give_wrong_torques(erratum, name, min_miss, scara_reflected, spherical):
    """D8, D9, D10: with the seed's printed element the recursion misses rne by > min_miss (N m or N,
    largest joint) in every one of 10 seeded states; the corrected recursion matches to 1e-10 relative.
    Observed smallest misses: D8 130 / 4.9, D9 15 / 3.6, D10 - / 0.73 (SCARA / spherical)."""
    robot = scara_reflected if name == "scara" else spherical
    rng = np.random.default_rng(2011)
    for q, qd, qdd in zip(*random_states(robot, rng, 10)):
        tau_model = rigid_body_rne(robot, q, qd, qdd)
        tau_p, _ = seed_newton_euler(robot.description, q, qd, qdd, robot.description.gravity, printed=(erratum,))
        assert np.abs(tau_p - tau_model).max() > min_miss


def test_d10_has_no_effect_on_the_scara(scara_reflected):
    """On the SCARA w_3 and the quill axis are both vertical: the corrected and the printed Coriolis
    terms of the prismatic joint both vanish, so D10 shows only on an arm like the spherical one."""
    robot = scara_reflected
    rng = np.random.default_rng(2012)
    for q, qd, qdd in zip(*random_states(robot, rng, 5)):
        tau_c, _ = seed_newton_euler(robot.description, q, qd, qdd, robot.description.gravity)
        tau_p, _ = seed_newton_euler(robot.description, q, qd, qdd, robot.description.gravity, printed=("D10",))
        np.testing.assert_allclose(tau_p, tau_c, rtol=0, atol=1e-12 * np.abs(tau_c).max())
