"""The README's examples run from a clone alone (no ../shared needed)."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
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


def _sh_block_after(marker: str) -> list[list[str]]:
    """The commands of the first ```sh block after ``marker`` in the README, as argv lists."""
    import shlex

    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8")
    block = readme.split(marker, 1)[1].split("```sh\n", 1)[1].split("```", 1)[0]
    return [shlex.split(cmd) for cmd in block.replace("\\\n", " ").splitlines() if cmd.strip()]


def test_readme_navigation_mode_example_runs_as_written(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(Path(__file__).resolve().parents[1])
    commands = _sh_block_after("**Navigation-mode refinement, step by step**")
    assert [c[1] for c in commands] == ["simulate", "fit", "nav-simulate", "nav-calibrate"]
    for argv in commands:
        assert argv[0] == "inertest"
        args = [str(tmp_path / a) if a in ("rotation.csv", "start.json", "turns.parquet",
                                           "nav-report") else a for a in argv[1:]]
        if ">" in args:  # `... --json > start.json`
            k = args.index(">")
            capsys.readouterr()
            assert main(args[:k]) == 0
            Path(args[k + 1]).write_text(capsys.readouterr().out)
        else:
            assert main(args) == 0
    out = capsys.readouterr().out
    rms = [float(x) for x in re.findall(r"│\s+\d+\s+│\s+([\d.e+-]+)\s+│", out)]
    assert len(rms) >= 3 and rms[0] > 1 and rms[1] < 0.1 and rms[-1] < 1e-3, out
    assert (tmp_path / "nav-report" / "index.html").is_file()


def test_readme_recordings_example_on_the_shipped_bag(examples_dir, tmp_path, capsys):
    pytest.importorskip("rosbags")
    [argv] = [c for c in _sh_block_after("## Recordings: ROS bags")]
    assert argv[:3] == ["inertest", "noise", "examples/recordings/lasergyro.bag"]
    bag = examples_dir / "recordings" / "lasergyro.bag"
    assert (bag.parent / "LICENSE").is_file() and (bag.parent / "README.md").is_file()
    kalibr = tmp_path / "imu.yaml"
    assert main(["noise", str(bag), *argv[3:-1], str(kalibr)]) == 0
    y = yaml.safe_load(kalibr.read_text())
    assert y["rostopic"] == "/imu" and y["update_rate"] == 100
    # 300 s of the PSINS recording: the bag's samples are read_psins' rates, bit for bit
    from inertest.io.imu_recording import read_psins

    ref = read_psins(examples_dir / "noise" / "lasergyro.imu.xz")
    got = inertest.load_data(bag)
    assert np.array_equal(got["angular_velocity.z"], ref.gyro[:30000, 2])
    assert np.array_equal(got["linear_acceleration.x"], ref.accel[:30000, 0])
