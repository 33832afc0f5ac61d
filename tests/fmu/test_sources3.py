"""FMI 3.0 source FMUs: two robots' ``sources/`` linked statically into one program, each with its FMI3_FUNCTION_PREFIX.

The FMU ships the standard FMI 3.0 headers, which turn ``fmi3DoStep`` into
``<prefix>fmi3DoStep``; the wrapper's internal functions (``mw_*``, the plant's
step rule) must take the same prefix, or the two models clash at link time
(``multiple definition of mw_do_step``). A small C program drives both models
(Co-Simulation, a constant torque on joint 1) and prints ``q[1]``; the numbers
must equal FMPy's runs of the two binaries (same C, same flags: identical to the
last bit is expected, 1e-12 allows for nothing but a different compiler's rounding).
"""

from __future__ import annotations

import subprocess
import xml.etree.ElementTree as ET
import zipfile
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

from fmu.build import CFLAGS
from fmu.simulate import simulate_cs, step_input

from tests.support.fmu_support import _quiet, build_root

STEPS = 200
H = 1e-3
TAU = 0.05

MAIN_C = r"""
#include <stdio.h>
#include <stdlib.h>
#include "fmi3FunctionTypes.h"

#define DECLARE(p)                                                  \
    fmi3InstantiateCoSimulationTYPE p##fmi3InstantiateCoSimulation; \
    fmi3EnterInitializationModeTYPE p##fmi3EnterInitializationMode; \
    fmi3ExitInitializationModeTYPE p##fmi3ExitInitializationMode;   \
    fmi3SetFloat64TYPE p##fmi3SetFloat64;                           \
    fmi3GetFloat64TYPE p##fmi3GetFloat64;                           \
    fmi3DoStepTYPE p##fmi3DoStep;                                   \
    fmi3TerminateTYPE p##fmi3Terminate;                             \
    fmi3FreeInstanceTYPE p##fmi3FreeInstance;
DECLARE(scara_)
DECLARE(planar2r_)

static void logger(fmi3InstanceEnvironment e, fmi3Status s, fmi3String c, fmi3String m) {
    (void)e; (void)s;
    fprintf(stderr, "%s: %s\n", c, m);
}

#define RUN(p, token, vr_tau, vr_q, n)                                                           \
    do {                                                                                         \
        fmi3ValueReference vr_u = (vr_tau), vr_x = (vr_q);                                       \
        fmi3Float64 tau[n] = {TAU}, q[n];                                                        \
        fmi3Boolean event, terminate, early;                                                     \
        fmi3Float64 last;                                                                        \
        int k, bad = 0;                                                                          \
        fmi3Instance c = p##fmi3InstantiateCoSimulation(#p, token, NULL, fmi3False, fmi3False,   \
                                                        fmi3False, fmi3False, NULL, 0, NULL,     \
                                                        logger, NULL);                           \
        if (c == NULL) return 1;                                                                 \
        bad |= p##fmi3EnterInitializationMode(c, fmi3False, 0.0, 0.0, fmi3False, 0.0);           \
        bad |= p##fmi3ExitInitializationMode(c);                                                 \
        bad |= p##fmi3SetFloat64(c, &vr_u, 1, tau, n);                                           \
        for (k = 0; k < STEPS; k++)                                                              \
            bad |= p##fmi3DoStep(c, k * H, H, fmi3True, &event, &terminate, &early, &last);      \
        bad |= p##fmi3GetFloat64(c, &vr_x, 1, q, n);                                             \
        bad |= p##fmi3Terminate(c);                                                              \
        p##fmi3FreeInstance(c);                                                                  \
        if (bad) return 1;                                                                       \
        printf("%s %.17g\n", #p, q[0]);                                                          \
    } while (0)

int main(void) {
    RUN(scara_, SCARA_TOKEN, SCARA_VR_TAU, SCARA_VR_Q, SCARA_N);
    RUN(planar2r_, PLANAR2R_TOKEN, PLANAR2R_VR_TAU, PLANAR2R_VR_Q, PLANAR2R_N);
    return 0;
}
"""


@lru_cache(maxsize=None)
def _fmu3(robot: str) -> Path:
    from fmu import export_fmu

    return _quiet(export_fmu, robot, build_root() / f"{robot}_src_fmi3.fmu", fmi_version=3)


def _md_facts(fmu_path: Path) -> dict[str, object]:
    from fmu.opened import open_fmu

    with open_fmu(fmu_path) as fmu:
        md = fmu.md
    vr = {v.name: v.valueReference for v in md.modelVariables}
    n = sum(1 for v in md.modelVariables if v.name == "tau_m") and int(
        next(v for v in md.modelVariables if v.name == "tau_m").dimensions[0].start)
    return {"id": md.coSimulation.modelIdentifier, "token": md.guid, "tau": vr["tau_m"], "q": vr["q"], "n": n}


def _compile_sources(cc: str, fmu_path: Path, prefix: str, work: Path) -> list[str]:
    """Compile every source file of the FMU's buildDescription.xml with FMI3_FUNCTION_PREFIX=prefix."""
    src = work / prefix
    with zipfile.ZipFile(fmu_path) as zf:
        for name in zf.namelist():
            if name.startswith("sources/"):
                zf.extract(name, src)
    files = [e.get("name") for e in ET.parse(src / "sources" / "buildDescription.xml").iter("SourceFile")]
    assert "fmi3_functions.c" in files and "instance.c" in files
    objects = []
    flags = [f for f in CFLAGS if f not in ("-fPIC", "-Werror")]
    for name in files:
        obj = work / f"{prefix}{Path(name).stem}.o"
        proc = subprocess.run([cc, *flags, f"-DFMI3_FUNCTION_PREFIX={prefix}", f"-I{src / 'sources'}", "-c",
                               str(src / "sources" / name), "-o", str(obj)], capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr
        objects.append(str(obj))
    return objects


@pytest.mark.fmi3
@pytest.mark.parametrize("cc", ["gcc", pytest.param("clang", marks=pytest.mark.needs("clang"))])
def test_two_fmi3_source_fmus_link_statically_into_one_program(cc, tmp_path):
    scara, planar = _fmu3("scara"), _fmu3("planar2r")
    s, p = _md_facts(scara), _md_facts(planar)
    assert (s["id"], p["id"]) == ("scara", "planar2r")
    objects = _compile_sources(cc, scara, "scara_", tmp_path) + _compile_sources(cc, planar, "planar2r_", tmp_path)
    main = tmp_path / "main.c"
    main.write_text(MAIN_C)
    exe = tmp_path / "two_models"
    defines = [f'-DSCARA_TOKEN="{s["token"]}"', f"-DSCARA_VR_TAU={s['tau']}", f"-DSCARA_VR_Q={s['q']}",
               f"-DSCARA_N={s['n']}", f'-DPLANAR2R_TOKEN="{p["token"]}"', f"-DPLANAR2R_VR_TAU={p['tau']}",
               f"-DPLANAR2R_VR_Q={p['q']}", f"-DPLANAR2R_N={p['n']}", f"-DSTEPS={STEPS}", f"-DH={H!r}",
               f"-DTAU={TAU!r}"]
    proc = subprocess.run([cc, "-std=c99", "-O2", "-ffp-contract=off", *defines,
                           f"-I{tmp_path / 'scara_' / 'sources'}", str(main), *objects, "-o", str(exe), "-lm"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr          # no duplicate symbol between the two models
    nm = subprocess.run(["nm", str(exe)], capture_output=True, text=True, check=True).stdout
    symbols = {line.split()[-1] for line in nm.splitlines()}
    assert {"scara_fmi3DoStep", "planar2r_fmi3DoStep", "scara_mw_do_step", "planar2r_mw_do_step",
            "scara_mw_plant_advance", "planar2r_mw_plant_advance"} <= symbols
    assert not {"fmi3DoStep", "mw_do_step", "mw_plant_advance"} & symbols
    run = subprocess.run([str(exe)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    got = dict(line.split() for line in run.stdout.splitlines())
    for fmu_path, prefix, n in ((scara, "scara_", s["n"]), (planar, "planar2r_", p["n"])):
        torque = np.zeros((1, n))
        torque[0, 0] = TAU
        table = step_input([f"tau_m[{i}]" for i in range(1, n + 1)], np.array([0.0]), torque)
        ref = simulate_cs(fmu_path, STEPS * H, H, inputs=table, outputs=["q[1]"])
        q_ref = ref["q[1]"][-1]
        assert abs(q_ref) > 1e-4                      # the torque moved the joint
        assert float(got[prefix]) == pytest.approx(q_ref, rel=0, abs=1e-12), prefix
