"""Source FMUs: two robots' ``sources/`` linked statically into one program, each with its FMI2_FUNCTION_PREFIX.

The FMU ships the standard FMI 2.0.1 headers, which turn ``fmi2DoStep`` into
``<prefix>fmi2DoStep``; the wrapper's internal functions take the prefix too.
A small C program drives both models (Co-Simulation, a constant torque on joint
1) and prints ``q[1]`` after each run; the numbers must equal FMPy's runs of the
two binaries (same C, same flags: identical to the last bit is expected, 1e-12
allows for nothing but a different compiler's rounding).
"""

from __future__ import annotations

import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest

from fmu.build import CFLAGS
from fmu.simulate import simulate_cs

from tests.support.fmu_support import planar2r_full_fmu, scara_fmu

STEPS = 200
H = 1e-3
TAU = 0.05

MAIN_C = r"""
#include <stdio.h>
#include <stdlib.h>
#include "fmi2FunctionTypes.h"

#define DECLARE(p)                                        \
    fmi2InstantiateTYPE p##fmi2Instantiate;               \
    fmi2SetupExperimentTYPE p##fmi2SetupExperiment;       \
    fmi2EnterInitializationModeTYPE p##fmi2EnterInitializationMode; \
    fmi2ExitInitializationModeTYPE p##fmi2ExitInitializationMode;   \
    fmi2SetRealTYPE p##fmi2SetReal;                       \
    fmi2GetRealTYPE p##fmi2GetReal;                       \
    fmi2DoStepTYPE p##fmi2DoStep;                         \
    fmi2TerminateTYPE p##fmi2Terminate;                   \
    fmi2FreeInstanceTYPE p##fmi2FreeInstance;
DECLARE(scara_)
DECLARE(planar2r_)

static void logger(fmi2ComponentEnvironment e, fmi2String n, fmi2Status s, fmi2String c, fmi2String m, ...) {
    (void)e; (void)s; (void)c;
    fprintf(stderr, "%s: %s\n", n, m);
}

#define RUN(p, guid, vr_tau)                                                                 \
    do {                                                                                     \
        fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};                       \
        fmi2ValueReference vr_q = 0, vr_u = (vr_tau);                                        \
        fmi2Real tau = TAU, q = 0.0;                                                         \
        int k, bad = 0;                                                                      \
        fmi2Component c = p##fmi2Instantiate(#p, fmi2CoSimulation, guid, "", &cb, 0, 0);    \
        if (c == NULL) return 1;                                                             \
        bad |= p##fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);                               \
        bad |= p##fmi2EnterInitializationMode(c);                                            \
        bad |= p##fmi2ExitInitializationMode(c);                                             \
        bad |= p##fmi2SetReal(c, &vr_u, 1, &tau);                                            \
        for (k = 0; k < STEPS; k++) bad |= p##fmi2DoStep(c, k * H, H, 1);                    \
        bad |= p##fmi2GetReal(c, &vr_q, 1, &q);                                              \
        bad |= p##fmi2Terminate(c);                                                          \
        p##fmi2FreeInstance(c);                                                              \
        if (bad) return 1;                                                                   \
        printf("%s %.17g\n", #p, q);                                                         \
    } while (0)

int main(void) {
    RUN(scara_, SCARA_GUID, SCARA_VR_TAU);
    RUN(planar2r_, PLANAR2R_GUID, PLANAR2R_VR_TAU);
    return 0;
}
"""


def _md_facts(fmu_path: Path) -> tuple[str, str, int]:
    from fmu.opened import open_fmu

    with open_fmu(fmu_path) as fmu:
        md = fmu.md
    vr_tau = next(v.valueReference for v in md.modelVariables if v.name == "tau_m[1]")
    return md.coSimulation.modelIdentifier, md.guid, vr_tau


def _compile_sources(cc: str, fmu_path: Path, prefix: str, work: Path) -> list[str]:
    """Compile every source file of the FMU's build description with FMI2_FUNCTION_PREFIX=prefix."""
    from fmu.opened import open_fmu

    src = work / prefix
    with zipfile.ZipFile(fmu_path) as zf:
        for name in zf.namelist():
            if name.startswith("sources/"):
                zf.extract(name, src)
    with open_fmu(fmu_path) as fmu:
        md = fmu.md
    files = md.buildConfigurations[0].sourceFileSets[0].sourceFiles
    objects = []
    flags = [f for f in CFLAGS if f not in ("-fPIC", "-Werror")]
    for name in files:
        obj = work / f"{prefix}{Path(name).stem}.o"
        proc = subprocess.run([cc, *flags, f"-DFMI2_FUNCTION_PREFIX={prefix}", f"-I{src / 'sources'}", "-c",
                               str(src / "sources" / name), "-o", str(obj)], capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr
        objects.append(str(obj))
    return objects


@pytest.mark.parametrize("cc", ["gcc", pytest.param("clang", marks=pytest.mark.needs("clang"))])
def test_two_source_fmus_link_statically_into_one_program(cc, tmp_path):
    scara, planar = scara_fmu(), planar2r_full_fmu()
    (sid, sguid, svr), (pid, pguid, pvr) = _md_facts(scara), _md_facts(planar)
    assert (sid, pid) == ("scara", "planar2r")
    objects = _compile_sources(cc, scara, "scara_", tmp_path) + _compile_sources(cc, planar, "planar2r_", tmp_path)
    main = tmp_path / "main.c"
    main.write_text(MAIN_C)
    exe = tmp_path / "two_models"
    defines = [f'-DSCARA_GUID="{sguid}"', f"-DSCARA_VR_TAU={svr}", f'-DPLANAR2R_GUID="{pguid}"',
               f"-DPLANAR2R_VR_TAU={pvr}", f"-DSTEPS={STEPS}", f"-DH={H!r}", f"-DTAU={TAU!r}"]
    proc = subprocess.run([cc, "-std=c99", "-O2", "-ffp-contract=off", *defines,
                           f"-I{tmp_path / 'scara_' / 'sources'}", str(main), *objects, "-o", str(exe), "-lm"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr          # no duplicate symbol between the two models
    nm = subprocess.run(["nm", str(exe)], capture_output=True, text=True, check=True).stdout
    symbols = {line.split()[-1] for line in nm.splitlines()}
    assert {"scara_fmi2DoStep", "planar2r_fmi2DoStep", "scara_mw_do_step", "planar2r_mw_do_step"} <= symbols
    assert not {"fmi2DoStep", "mw_do_step"} & symbols
    run = subprocess.run([str(exe)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    got = dict(line.split() for line in run.stdout.splitlines())
    for fmu_path, prefix in ((scara, "scara_"), (planar, "planar2r_")):
        ref = simulate_cs(fmu_path, STEPS * H, H, outputs=["q[1]"], start_values={"tau_m[1]": TAU})
        q_ref = ref["q[1]"][-1]
        assert abs(q_ref) > 1e-4                      # the torque moved the joint
        assert float(got[prefix]) == pytest.approx(q_ref, rel=0, abs=1e-12), prefix
    assert np.isfinite([float(v) for v in got.values()]).all()
