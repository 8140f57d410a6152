"""The orientation-free fit's headline checks in the terminal (issue 30), as in the JSON."""

from __future__ import annotations

import json
import re
from pathlib import Path

from inertest.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "orientation_free"


def test_attitudes_and_both_gravity_checks_are_printed(capsys):
    argv = ["fit", str(EXAMPLES / "plan_xsens.toml"), str(EXAMPLES / "xsens_mti.parquet"),
            "--no-store"]
    assert main([*argv, "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)["result"]["summary"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "attitudes found: 38 static intervals, detector threshold 6 x the initial variance" \
        in out
    norm = re.search(r"\|a\| - g over the attitudes \(RMS\): ([\d.]+) mg raw -> ([\d.]+) mg "
                     r"calibrated", out)
    carry = re.search(r"gravity carried by the gyros between attitudes \(RMS angle error\): "
                      r"([\d.]+) deg raw -> ([\d.]+) deg calibrated", out)
    assert norm and carry, out
    for m, key in ((norm, "gravity_norm_rms"), (carry, "gravity_transport_rms")):
        before, after = (float(v) for v in m.groups())
        assert f"{summary[key]['before']:.4g}" == m.group(1)
        assert f"{summary[key]['after']:.4g}" == m.group(2)
        assert after < before
