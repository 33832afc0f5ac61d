"""The numbers the docs print are the numbers the code computes, to the digits printed.

``docs/control-design.md`` shows the SCARA's PD design (50 rad/s, damping 0.7, 1 kHz) as a table; this
test recomputes every cell and every figure of the summary line below it. A printed number with k
decimals must equal the computed one to half a unit of its last digit.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from control_design.design import design_robot
from model.robot import load_robot

DOC = Path(__file__).resolve().parents[2] / "docs" / "control-design.md"


def _close(printed: str, value: float) -> bool:
    mantissa = printed.split("e")[0]
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    exponent = int(printed.split("e")[1]) if "e" in printed else 0
    return abs(float(printed) - value) <= 0.5 * 10.0 ** (exponent - decimals) * (1 + 1e-9)


@pytest.fixture(scope="module")
def design():
    return design_robot(load_robot("scara"), "pd", 50.0, 0.7, rate_hz=1000.0)


def _table_rows() -> dict[str, list[str]]:
    text = DOC.read_text()
    section = text.split("## SCARA, PD at 50 rad/s, zeta 0.7, 1 kHz")[1].split("\n## ")[0]
    rows = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 7 and cells[0] in ("shoulder", "elbow", "quill", "wrist"):
            rows[cells[0]] = cells[1:]
    return rows


def test_the_design_table_matches_the_design(design):
    rows = _table_rows()
    assert len(rows) == 4  # negative control: the table is found and read
    for j, report in enumerate(design.reports):
        J, Kp, Kd, wc, pm, gm = rows[report.name]
        J_eff = design.model.J_eff_m[j]
        assert _close(J.split("..")[-1], J_eff), (report.name, J, J_eff)
        assert _close(Kp, report.Kp_m) and _close(Kd, report.Kd_m), (report.name, Kp, Kd)
        assert _close(wc, report.crossover), (report.name, wc, report.crossover)
        pm_c, pm_d = re.findall(r"[\d.]+", pm)
        assert _close(pm_c, report.phase_margin) and _close(pm_d, report.phase_margin_d), (report.name, pm)
        gm_db = re.findall(r"[\d.]+", gm)[0]
        assert _close(gm_db, 20 * math.log10(report.gain_margin_d)), (report.name, gm, report.gain_margin_d)


def test_the_summary_line_matches_the_design(design):
    text = DOC.read_text()
    line = re.search(r"All loops: bandwidth ([\d.]+) rad/s \(([\d.]+) sampled\), rise ([\d.]+) ms, "
                     r"overshoot ([\d.]+) %, settling ([\d.]+) ms\.", text)
    assert line is not None
    bw, bw_d, rise, overshoot, settling = line.groups()
    shoulder = design.reports[0]
    assert _close(bw, shoulder.bandwidth) and _close(bw_d, shoulder.bandwidth_d)
    assert _close(rise, shoulder.rise_time * 1e3) and _close(overshoot, shoulder.overshoot)
    assert _close(settling, shoulder.settling_time * 1e3)
    loss = re.search(r"Sampling costs ([\d.]+) deg of phase margin against `w_c T / 2` = ([\d.]+) deg", text)
    assert _close(loss.group(1), shoulder.phase_margin_loss) and _close(loss.group(2), shoulder.phase_margin_loss_zoh)
