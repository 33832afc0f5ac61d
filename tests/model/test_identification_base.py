"""Base parameters against the literature and a closed form derived here by hand.

* Puma 560: 36 inertial base parameters (Mayeda, Yoshida and Osuka, "Base parameters of manipulator dynamic
  models", IEEE Trans. RA 6(3), 1990; Gautier, "Numerical calculation of the base inertial parameters of
  robots", J. Robotic Systems 8(4), 1991, both for the Puma's geometry: joint 1 along gravity, one inertial
  parameter for link 1 and seven for each of links 2-6). With rotor inertias: Ia_1 regroups with link 1 and
  Ia_2 with I_zz2 (axis 2 is perpendicular to axis 1, so link 2 spins about z_2 at qd_2 alone), the other
  four add one each: 40; friction and offset add 3 per joint: 58.
* Planar 2R in a vertical plane (``planar2r``: a1 = a2 = 1 m, gravity in the plane, link frames at the far
  end of each link): the seven combinations written out below from the kinetic and potential energy, in the
  standard parameters of this package. The numerical basis must span exactly their row space.
* For every built-in: ``Y pi = Y_b (K pi)`` at fresh random states (1e-12 relative).
* The counts of docs/identification.md are the computed ones.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from model.identification.base import base_parameters, random_states
from model.identification.parameters import ParameterKind, parameter_names
from model.identification.regressor import Regressor
from model.loading import load_description
from tests.support.references import available_robots

DOC = Path(__file__).resolve().parents[2] / "docs" / "identification.md"


@pytest.mark.parametrize("name", available_robots())
def test_base_regressor_reproduces_the_torque_of_any_parameters(name):
    desc = load_description(name)
    reg = Regressor(desc)
    base = base_parameters(reg)
    Y = reg.batch(*random_states(desc, 30, seed=11))
    pi = np.random.default_rng(12).standard_normal(reg.size)
    tau = Y @ pi
    np.testing.assert_allclose(base.columns(Y) @ base.beta(pi), tau, rtol=0, atol=1e-12 * np.abs(tau).max())
    np.testing.assert_array_equal(base.K[:, list(base.independent)], np.eye(base.n_base))
    # a negative control: dropping one base column breaks it
    beta = base.beta(pi)
    beta[0] = 0.0
    assert np.abs(base.columns(Y) @ beta - tau).max() > 1e-6 * np.abs(tau).max()


def test_puma_counts_match_the_literature():
    reg = Regressor(load_description("puma560"))
    assert base_parameters(reg, kinds=(ParameterKind.INERTIAL,)).n_base == 36
    assert base_parameters(reg, kinds=(ParameterKind.INERTIAL, ParameterKind.ROTOR)).n_base == 40
    assert base_parameters(reg).n_base == 58


def _planar2r_closed_form(a1: float, a2: float) -> np.ndarray:
    """(7, 28) rows of the planar 2R's base parameters in our standard parameters.

    Each link's body frame sits on its joint with x along the link; link frame i is that frame moved a_i along x,
    so about the joint ``mc_x' = mc_x + a m`` and ``I_zz' = I_zz + 2 a mc_x + a^2 m``. The arm's kinetic and
    potential energy then depend on ``I_zz1' + Ia_1 + a1^2 m_2``, ``mc_x1' + a1 m_2``, ``mc_y1``, ``I_zz2'``,
    ``mc_x2'``, ``mc_y2`` and ``Ia_2``.
    """
    names = parameter_names(2)
    idx = {name: k for k, name in enumerate(names)}
    rows = []

    def row(**coef):
        r = np.zeros(len(names))
        for key, value in coef.items():
            r[idx[key]] += value
        rows.append(r)

    row(I_zz1=1, mc_x1=2 * a1, m_1=a1 ** 2, Ia_1=1, m_2=a1 ** 2)
    row(mc_x1=1, m_1=a1, m_2=a1)
    row(mc_y1=1)
    row(I_zz2=1, mc_x2=2 * a2, m_2=a2 ** 2)
    row(mc_x2=1, m_2=a2)
    row(mc_y2=1)
    row(Ia_2=1)
    return np.array(rows)


def test_planar_2r_spans_the_closed_form():
    desc = load_description("planar2r")
    base = base_parameters(Regressor(desc), kinds=(ParameterKind.INERTIAL, ParameterKind.ROTOR))
    K_cf = _planar2r_closed_form(desc.links[0].a, desc.links[1].a)
    assert base.n_base == 7
    assert np.linalg.matrix_rank(np.vstack([base.K, K_cf]), tol=1e-9) == 7
    # negative control: a wrong closed form (a1 instead of a1^2 in the first row) is not in the span
    wrong = K_cf.copy()
    wrong[0, parameter_names(2).index("m_2")] = 2.0 * desc.links[0].a
    assert np.linalg.matrix_rank(np.vstack([base.K, wrong]), tol=1e-9) == 8


def test_expressions_name_the_regrouped_parameters():
    base = base_parameters(Regressor(load_description("planar2r")))
    exprs = dict(zip(base.base_names, base.expressions()))
    assert exprs["mc_x1R"] == "mc_x1 + m_1 + m_2"
    assert exprs["I_zz1R"] == "I_zz1 - m_1 + Ia_1 - m_2"
    assert exprs["fv_2"] == "fv_2"


def _doc_counts() -> dict[str, tuple[int, int, int]]:
    rows = {}
    for line in DOC.read_text().splitlines():
        m = re.match(r"\|\s*`(\w+)`\s*\|\s*(\d+)\s*\|\s*(\d+)\s*\|\s*(\d+)\s*\|\s*(\d+)\s*\|", line)
        if m:
            rows[m.group(1)] = tuple(int(m.group(k)) for k in (3, 4, 5))
    return rows


def test_documented_counts_are_the_computed_ones():
    documented = _doc_counts()
    assert set(documented) == set(available_robots())
    for name, (inertial, rotor, total) in documented.items():
        reg = Regressor(load_description(name))
        got = (base_parameters(reg, kinds=(ParameterKind.INERTIAL,)).n_base,
               base_parameters(reg, kinds=(ParameterKind.INERTIAL, ParameterKind.ROTOR)).n_base,
               base_parameters(reg).n_base)
        assert got == (inertial, rotor, total), name
