"""The README's examples run from a clone alone (no ../shared needed)."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import yaml

import inertest
from inertest.cli import main
from inertest.io.data_file import read_table


def test_readme_ferraris_fit_and_apply_on_the_shipped_session(examples_dir, tmp_path, capsys):
    plan = examples_dir / "ferraris" / "plan_imucal.toml"
    data = examples_dir / "ferraris" / "imucal" / "annotated_session.csv"
    assert (data.parent / "LICENSE").is_file()
    assert main(["fit", str(plan), str(data), "--json", "--no-store"]) == 0
    cal = tmp_path / "cal.json"
    cal.write_text(capsys.readouterr().out)
    assert json.loads(cal.read_text())["kind"] == "ferraris"
    out = tmp_path / "calibrated.parquet"
    assert main(["apply", str(cal), str(data), "-o", str(out), "--gyr-unit", "deg/s"]) == 0
    got = read_table(out)
    # Static faces of the calibrated session: |a| is local gravity (the plan's 9.81 m/s^2).
    raw = read_table(data)
    still = np.isin(raw["part"], ["x_p", "x_a", "y_p", "y_a", "z_p", "z_a"])
    acc = np.column_stack([got[c] for c in got if c.startswith("acc")][:3])
    assert abs(np.median(np.linalg.norm(acc[still], axis=1)) - 9.81) < 0.01


def test_readme_noise_examples_on_the_shipped_psins_recording(examples_dir, tmp_path, capsys):
    # inertest noise examples/noise/lasergyro.imu.xz --kalibr imu.yaml --report noise-report
    data = examples_dir / "noise" / "lasergyro.imu.xz"
    assert (data.parent / "LICENSE").is_file()
    kalibr, report = tmp_path / "imu.yaml", tmp_path / "noise-report"
    assert main(["noise", str(data), "--kalibr", str(kalibr), "--report", str(report)]) == 0
    out = capsys.readouterr().out
    assert "accel_z" in out and "report:" in out
    y = yaml.safe_load(kalibr.read_text())
    assert y["update_rate"] == 100 and y["gyroscope_noise_density"] > 0
    # The record does not follow the five-term model: the yaml says its values are bounds.
    assert kalibr.read_text().count("UPPER BOUND, not a measurement") == 4
    html = (report / "index.html").read_text()
    assert html.count("data:image/png;base64,") >= 6
    # inertest noise examples/noise/lasergyro.imu.xz --compare examples/noise/datasheet.yaml
    assert main(["noise", str(data), "--compare", str(data.parent / "datasheet.yaml"),
                 "--json"]) == 0
    comp = json.loads(capsys.readouterr().out)["result"]["comparison"]
    # every term only bounded, the claims below the bounds: consistent, not shown
    assert len(comp) == 12 and {c["consistency"] for c in comp} == {"consistent with"}
    assert {c["verdict"] for c in comp} == {"not shown"}


def test_readme_polar_tumble_angle_convention_is_what_simulate_and_fit_use(examples_dir):
    # README: "in every mounting fI = γ cos L sin θ; O mountings: fS = γ cos L cos θ,
    # fO = +γ sin L (O-Np)". A gyro with DS = 1 deg/h/g only reads γ cos L at θ = 0 in O-Np and
    # nothing at θ = 90 deg; one with DI only reads 0 at θ = 0 and γ cos L at θ = 90 deg (the
    # reverse of an "I up at 0" convention, which swaps DI and DS).
    readme = (examples_dir.parent / "README.md").read_text(encoding="utf-8")
    para = " ".join(readme.split("**Polar-tumble angle convention.**")[1].split("\n\n")[0]
                    .split())
    assert "at θ = 0 the I axis is horizontal" in para
    assert "in every mounting fI = γ cos L sin θ" in para
    assert re.search(r"O mountings: fS = γ cos L cos θ, fO = \+γ sin L \(O-Np\)", para)
    plan = inertest.load_plan(examples_dir / "polar_tumble" / "plan.toml")
    lat = math.radians(34.246)                     # the plan's latitude
    gamma = plan.site.gravity_m_s2 / 9.80665       # g / g0
    st = 12.5                                      # deg/h per mA, the plan's scale factor
    for coef, at0, at90 in (("DS", gamma * math.cos(lat), 0.0),
                            ("DI", 0.0, gamma * math.cos(lat)),
                            ("DO", gamma * math.sin(lat), gamma * math.sin(lat))):
        d = inertest.simulate(plan, {coef: 1.0}, noise=0.0, rng=0)
        m, a, out = (np.asarray(d[k]) for k in ("mounting", "angle_deg", "output"))
        for angle, want in ((0.0, at0), (90.0, at90)):
            rows = (m == "O-Np") & np.isclose(a, angle)
            assert rows.any()
            np.testing.assert_allclose(out[rows] * st, want, atol=1e-12)
