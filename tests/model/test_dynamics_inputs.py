"""Bad input to the dynamics API gets a ValueError naming the argument, and changes nothing."""

from __future__ import annotations

import re

import numpy as np
import pytest

from model import load_robot
from model.dynamics import DynamicsParameters


@pytest.fixture(scope="module")
def scara():
    return load_robot("scara")


@pytest.mark.parametrize(
    ("index_name", "value", "message"),
    [
        ("payload_mass", -5.0, "p: mass: expected a finite number >= 0 kg, got -5.0"),
        ("coulomb_friction_pos[2]", -0.1, "p: coulomb_pos: expected values >= 0"),
        ("coulomb_friction_neg[1]", 0.1, "p: coulomb_neg: expected values <= 0"),
        ("viscous_friction[3]", -1e-3, "p: viscous: expected values >= 0"),
    ],
)
def test_a_parameter_vector_is_checked_field_by_field(scara, index_name, value, message):
    layout = scara.dynamics.layout
    before = scara.parameters
    p = before.vector.copy()
    p[layout.names.index(index_name)] = value
    with pytest.raises(ValueError, match=re.escape(message)):
        DynamicsParameters(layout, p)
    assert scara.parameters == before


def test_a_valid_parameter_vector_is_accepted_and_read_only(scara):
    layout = scara.dynamics.layout
    p = scara.parameters.vector.copy()
    p[layout.names.index("payload_mass")] = 2.0
    params = DynamicsParameters(layout, p)
    assert params.payload_mass == 2.0
    with pytest.raises(ValueError, match="read-only"):
        params.vector[0] = 1.0
    p[0] = 5.0  # the value kept its own copy
    assert params.payload_mass == 2.0


def test_parameters_of_another_layout_are_refused(scara):
    other = load_robot("planar2r")
    with pytest.raises(ValueError, match=re.escape("p: expected the parameters of 'scara'")):
        scara.rne(np.zeros(4), np.zeros(4), np.zeros(4), other.parameters)
    with pytest.raises(ValueError, match=re.escape("p: expected DynamicsParameters")):
        scara.rne(np.zeros(4), np.zeros(4), np.zeros(4), scara.parameters.vector)


def test_batch_rejects_non_finite_rows(scara):
    Q = np.zeros((3, 4))
    Q[1, 2] = np.nan
    with pytest.raises(ValueError, match=re.escape("Q: expected finite values; rows [1] are not")):
        scara.rne_batch(Q, np.zeros((3, 4)), np.zeros((3, 4)))


@pytest.mark.parametrize("shape", [(2, 2), (4, 1, 1)])
def test_joint_vector_shape_is_strict(scara, shape):
    with pytest.raises(ValueError, match=re.escape(f"q: expected 4 joint values, got an array of shape {shape}")):
        scara.fkine(np.zeros(shape))


@pytest.mark.parametrize("shape", [(4,), (4, 1), (1, 4)])
def test_joint_vector_accepts_row_and_column(scara, shape):
    assert scara.fkine(np.zeros(shape)).shape == (4, 4)


def test_substeps_follow_the_plant_friction_as_set():
    from closed_loop import default_substeps

    plant = load_robot("planar2r")
    q0 = plant.q_rest
    base = default_substeps(plant, 1e-3, q0)
    stiff = plant.with_parameters(plant.parameters.with_friction(viscous=[50.0, 50.0]))  # 5000x the file's
    assert default_substeps(stiff, 1e-3, q0) > base
    assert default_substeps(plant, 1e-3, q0) == base
