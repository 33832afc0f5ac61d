"""The opened-FMU object and the instance adapter (fmu/opened.py, fmu/instance.py) on FMI 2.0 and 3.0.

References: the two FMUs of one robot evaluate the same generated C, so the adapter must give bit-identical
numbers through either version; the FMU's own refusals (a NaN input) must come back as FmuCallError with the
FMU's message; FMI 3.0's adjoint must be the transpose of its forward mode (to rounding: 1e-12 relative,
both are CasADi's AD of one expression graph).
"""

from __future__ import annotations

import zipfile
from functools import lru_cache

import numpy as np
import pytest

from fmu.archive import FmuArchiveError
from fmu.instance import FmuCallError
from fmu.opened import open_fmu
from model.errors import InputError
from tests.support.fmu_support import build_root, puma_fmu


@lru_cache(maxsize=None)
def puma3_fmu():
    from fmu import export_fmu

    return export_fmu("puma560", build_root() / "puma560_fmi3.fmu", fmi_version=3)


N = 6
X = [f"q[{i + 1}]" for i in range(N)] + [f"qd[{i + 1}]" for i in range(N)]
TAU = [f"tau_m[{i + 1}]" for i in range(N)]


def _cs_run(path, fast: bool) -> np.ndarray:
    out = []
    with open_fmu(path) as fmu, fmu.instance("cs", "plant") as inst:
        inst.start(0.0)
        read = inst.reader(X)
        buf, write = inst.writer(TAU)
        step = inst.stepper()
        for k in range(300):
            tau = 2.0 * np.sin(0.02 * k + np.arange(N))
            if fast:
                buf[:] = tau
                write()
                step(k * 1e-3, 1e-3)
                out.append(read().copy())
            else:
                inst.set(TAU, tau)
                inst.do_step(k * 1e-3, 1e-3)
                out.append(inst.get(X))
    return np.array(out)


def test_fmi2_and_fmi3_give_the_same_run_through_either_path():
    runs = [_cs_run(p, fast) for p in (puma_fmu(), puma3_fmu()) for fast in (True, False)]
    assert np.ptp(runs[0][:, :N], axis=0).max() > 1e-3  # the arm moved
    for other in runs[1:]:
        assert np.array_equal(runs[0], other)


@pytest.mark.parametrize("version", [2, 3])
def test_a_refused_call_raises_with_the_fmus_message(version):
    path = puma_fmu() if version == 2 else puma3_fmu()
    with open_fmu(path) as fmu, fmu.instance("cs", "plant") as inst:
        inst.start(0.0)
        with pytest.raises(FmuCallError) as info:
            inst.set(TAU, [np.nan] + [0.0] * (N - 1))
        err = info.value
        assert err.status == 3 and f"fmi{version}Set" in err.function
        assert path.name in str(err) and "not finite" in str(err)
        assert inst.status("setReal" if version == 2 else "setFloat64", [fmu.vr("tau_m[1]" if version == 2
                                                                              else "tau_m")],
                           [np.nan] * (1 if version == 2 else N)) == 3


def test_names_resolve_and_unknown_names_are_refused():
    with open_fmu(puma3_fmu()) as f3, open_fmu(puma_fmu()) as f2:
        sel = f3.select(["qd[2]", "q[6]", "q[1]"])
        assert sel.vrs == (f3.vr("qd"), f3.vr("q")) and sel.sizes == (N, N) and sel.where == (1, N + 5, N)
        assert f3.derivative_names()[:2] == ["der(q)[1]", "der(q)[2]"]
        assert f2.derivative_names()[:2] == ["der(q[1])", "der(q[2])"]
        for f in (f2, f3):
            with pytest.raises(InputError, match=r"no variable 'q\[7\]'"):
                f.select(["q[7]"])
            assert f.names("input") == TAU


def test_a_file_that_is_not_an_fmu_is_refused_before_fmpy(tmp_path):
    bad = tmp_path / "bad.fmu"
    with zipfile.ZipFile(bad, "w") as zf:
        zf.writestr("../evil.txt", "x")
    with pytest.raises(FmuArchiveError, match="bad.fmu"):
        open_fmu(bad)


def test_directional_and_adjoint_derivatives_agree_across_versions():
    J = {}
    for path in (puma_fmu(), puma3_fmu()):
        with open_fmu(path) as fmu, fmu.instance("me", "m") as m:
            m.start(0.0)
            m.set_x(m.get_x() + 0.3)
            der = fmu.derivative_names()
            J[fmu.fmi_version] = np.column_stack([m.directional(der, TAU, np.eye(N)[j]) for j in range(N)])
            if fmu.fmi_version == 3:
                JT = np.vstack([m.adjoint(der, TAU, np.eye(2 * N)[i]) for i in range(2 * N)])
                assert np.max(np.abs(JT - J[3])) <= 1e-12 * np.max(np.abs(J[3]))
            else:
                with pytest.raises(InputError, match="no adjoint"):
                    m.adjoint(der, TAU, np.ones(2 * N))
    assert np.max(np.abs(J[3][N:])) > 0  # torques move the accelerations
    assert np.array_equal(J[2], J[3])
