"""The C limits of the wrapper come from the Python constants: ``sources/mw_limits.h`` is rendered, not written.

``MW_MAX_SUBSTEPS`` and ``MW_SUBSTEP_RTOL`` used to be typed twice (``fmu/c/instance.h``
and ``fmu/variables.py``), tied by a comment. Now an FMU's header carries the
Python numbers, and an FMU built with another ``MAX_SUBSTEPS`` refuses a
``DoStep`` at exactly that other bound (the negative control: the default
bound, 1e6, would accept it).
"""

from __future__ import annotations

import re
import zipfile

import pytest

import fmu.limits
from fmu.build import C_DIR
from fmu.variables import MAX_SUBSTEPS, SUBSTEP_RTOL

from tests.support.fmu_support import scara_fmu


def test_the_fmu_ships_the_rendered_limits():
    with zipfile.ZipFile(scara_fmu()) as zf:
        header = zf.read("sources/mw_limits.h").decode()
    assert "generated, do not edit" in header.splitlines()[0]
    assert re.search(r"^#define MW_MAX_SUBSTEPS (\d+)ull$", header, re.M).group(1) == str(MAX_SUBSTEPS)
    assert float(re.search(r"^#define MW_SUBSTEP_RTOL (\S+)$", header, re.M).group(1)) == SUBSTEP_RTOL


def test_no_handwritten_copy_of_the_limits_is_left():
    for path in C_DIR.glob("*.[ch]"):
        text = path.read_text()
        assert not re.search(r"#define\s+MW_(MAX_SUBSTEPS|SUBSTEP_RTOL)\b", text), path.name


def test_an_fmu_built_with_another_bound_enforces_that_bound(tmp_path, monkeypatch):
    from fmpy.fmi2 import fmi2Error

    from fmu import export_trivial_fmu
    from fmu.instance import FmuCallError
    from fmu.opened import open_fmu

    monkeypatch.setattr(fmu.limits, "MAX_SUBSTEPS", 1000)
    path = export_trivial_fmu(tmp_path / "small_bound.fmu", step=1e-3)
    with open_fmu(path) as opened, opened.instance("cs", "bound") as slave:
        assert "#define MW_MAX_SUBSTEPS 1000ull" in opened.member("sources/mw_limits.h").decode()
        slave.start(0.0)
        slave.do_step(0.0, 1.0)                              # 1000 sub-steps of 1 ms: the most one call takes
        with pytest.raises(FmuCallError) as err:
            slave.do_step(1.0, 1.001)                        # 1001: refused by this FMU, accepted under 1e6
        assert err.value.status == fmi2Error
