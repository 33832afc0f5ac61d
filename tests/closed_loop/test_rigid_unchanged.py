"""A rigid robot's closed loop gives the numbers it gave before drive trains existed, bit for bit (issue 23).

The reference is the run of the same script on commit 43fb6b5 (main before the drive trains), this machine's
compiler and libm (gcc, glibc): the SHA-256 of the float64 bytes of ``[t, q, qd, tau_m]`` over 2 s, and the last
row printed to 17 digits. Another compiler may round a last bit differently (the engines agree to rounding,
not across compilers); the last row's 1e-12 check then still holds and says so.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from closed_loop.simulate import simulate_tracking
from control_design.design import design_robot
from control_design.reference import task_trajectory
from model.robot import load_robot

_MAIN = {  # robot, controller -> (sha256, last row) of commit 43fb6b5
    ("scara", "pd"): ("7463c47e6f287e225da9b4f33d2f14d86fda812c4aa718ad6c3c64aa7b51688d",
                      [2.0, 1.2438045117894139, 1.2431985198895337, 1.022980859156907, -9.309467786165418e-06,
                       0.7770756733984555, 0.7847026997447056, -1.0165435921813398e-13, -1.7703348396941027e-05,
                       4.759321192097206, -0.5024701181885014, 1.1872908764900856, 1.0321532190356269e-05]),
    ("puma560", "pid"): ("ff00246b58fb688319da1fa13b073b6b5fa14449741bb3cd240850edd23b16fb",
                         [2.0, -1.104584298248552, 0.31082824140450227, -2.1748494565547136, -0.5522697401806116,
                          -0.6903424649626093, -1.835953641087462, -0.6889007418338372, 0.19665836768120523,
                          -1.3548485172566518, -0.3452302563638642, -0.4316034154013807, -1.1465880686203815,
                          0.439219473591155, 0.5485691969861758, 0.03100675566692164, -0.017980749129364617,
                          -0.015839442789315886, -0.010807467722142456]),
}


@pytest.mark.parametrize("name, kind", list(_MAIN))
def test_rigid_closed_loop_is_unchanged(name, kind):
    robot = load_robot(name)
    design = design_robot(robot, kind, 20.0, 0.7, phase_margin=None, rate_hz=1000.0, analyse=False)
    res = simulate_tracking(robot, design.controller(1000.0), task_trajectory(robot, None, None, None), t_final=2.0)
    data = np.ascontiguousarray(np.column_stack([res.t, res.q, res.qd, res.tau_m]))
    digest, last = _MAIN[(name, kind)]
    np.testing.assert_allclose(data[-1], last, rtol=1e-12, atol=1e-15)
    assert hashlib.sha256(data.tobytes()).hexdigest() == digest
