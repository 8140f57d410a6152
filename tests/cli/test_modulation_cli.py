import json

from inertest.cli import main


def test_component_json_and_plot(tmp_path, capsys):
    png = tmp_path / "m.png"
    assert main(["modulation", "component", "--stator-hz", "1,4", "--sample-hz", "400",
                 "--duration-s", "20", "--drift-deg-h", "5,-3", "--json",
                 "--plot", str(png)]) == 0
    out = json.loads(capsys.readouterr().out)["result"]
    r1, r4 = out["runs"]
    # rms over both axes of the constant drift (5, -3) deg/h = sqrt(17)
    assert abs(r1["rms_residual_fixed_deg_h"] - 17.0**0.5) < 1e-9
    assert r1["rms_residual_modulated_deg_h"] < 1e-9
    assert r4["delay_s"] == 0.125
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_component_bad_input(capsys):
    assert main(["modulation", "component", "--stator-hz", "3", "--sample-hz", "1000"]) == 2
    assert "whole number" in capsys.readouterr().err
    assert main(["modulation", "component", "--stator-hz", "0"]) == 2
    assert "positive" in capsys.readouterr().err


def test_system_json_single_scheme(capsys):
    assert main(["modulation", "system", "--latitude", "30", "--hours", "2", "--step", "600",
                 "--scheme", "single-axis", "--rate-deg-s", "6", "--gyro-drift-deg-h", "0,0,0.01",
                 "--accel-bias-ug", "0,0,0", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)["result"]
    assert out["scheme"] == "single-axis"
    assert out["t"] == [0.0, 600.0, 1200.0, 1800.0, 2400.0, 3000.0, 3600.0, 4200.0, 4800.0,
                        5400.0, 6000.0, 6600.0, 7200.0]
    for s in ("dVE", "dVN", "dL", "dlambda", "phiE", "phiN", "phiU"):
        assert len(out[s]) == 13
    assert out["units"]["phiU"] == "rad" and out["units"]["dVE"] == "m/s"
    # vertical drift is untouched by vertical rotation: phiU' ~ -eU at first (0.01 deg/h of
    # gyro output error turns the computed frame the other way)
    assert abs(out["phiU"][1] + 0.01 * 3.141592653589793 / 180 / 3600 * 600) < 1e-3 * abs(
        out["phiU"][1])
    assert "output errors" in out["sign_convention"]
    assert out["imu"]["gyro_drift"]["unit"] == "rad/s"


def test_system_compare_table_and_plot(tmp_path, capsys):
    png, html = tmp_path / "s.png", tmp_path / "s.html"
    assert main(["modulation", "system", "--hours", "6", "--compare", "--rate-deg-s", "10",
                 "--dwell-s", "30", "--plot", str(png), "--report", str(html)]) == 0
    out = capsys.readouterr().out
    for name in ("none", "single-axis (alternating)", "four-position", "sixteen-position"):
        assert name in out
    assert "horizontal position [m]" in out and "[arcsec]" in out
    assert "equivalent constant IMU errors" in out and "eU [deg/h]" in out
    assert png.read_bytes()[:4] == b"\x89PNG"
    page = html.read_text(encoding="utf-8")
    assert "What each scheme leaves" in page and "data:image/png;base64," in page


def test_system_compare_json(capsys):
    assert main(["modulation", "system", "--hours", "3", "--step", "300", "--compare",
                 "--rate-deg-s", "10", "--dwell-s", "30", "--gyro-drift-deg-h", "0.01,0.01,0",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)["result"]
    runs = {r["label"]: r["summary"] for r in out["runs"]}
    assert len(runs) == 5
    static = runs["none"]["max_phiE_rad"]
    for label in ("single-axis", "four-position", "sixteen-position"):
        assert runs[label]["max_phiE_rad"] < static / 5
    left = {r["label"]: r["cycle_mean_inputs"] for r in out["runs"]}
    assert left["none"]["eE"] == 0.01 * 3.141592653589793 / 180 / 3600
    assert left["sixteen-position"] == {"bE": 0.0, "bN": 0.0, "eE": 0.0, "eN": 0.0, "eU": 0.0}
    assert out["runs"][0]["units"]["cycle_mean_inputs"]["eE"] == "rad/s"


def test_system_bad_input(tmp_path, capsys):
    png = tmp_path / "never.png"
    assert main(["modulation", "system", "--scheme", "single-axis", "--rate-deg-s", "0",
                 "--plot", str(png)]) == 2
    assert "non-zero rate" in capsys.readouterr().err
    assert not png.exists()
    assert main(["modulation", "system", "--scheme", "sixteen-position", "--hours", "0.1"]) == 2
    assert "longer than the simulated span" in capsys.readouterr().err
    assert main(["modulation", "system", "--scheme", "four-position", "--dwell-s", "0"]) == 2
    assert "dwell" in capsys.readouterr().err
    assert main(["modulation", "system", "--gyro-drift-deg-h", "1,2"]) == 2
    assert "3 comma-separated" in capsys.readouterr().err
    assert main(["modulation", "system", "--step", "0"]) == 2
    assert "step" in capsys.readouterr().err


def test_system_gyro_misalignment_in_urad_by_triad_convention(capsys):
    """--gyro-misalignment-urad lists M_xy, M_xz, M_yx, M_yz, M_zx, M_zy: entry (0, 1) of the
    matrix is M_xy (gyro x, rate about y), in rad in the JSON."""
    assert main(["modulation", "system", "--hours", "1", "--step", "600", "--scheme", "none",
                 "--gyro-misalignment-urad", "5,0,0,0,0,0", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)["result"]
    m = out["imu"]["gyro_misalignment"]
    assert m["unit"] == "rad" and abs(m["value"][0][1] - 5e-6) < 1e-20
    assert m["value"][1][0] == 0.0


def test_scheme_choices_are_the_studys():
    # The command spells the schemes out so that --help does not load the study (start-up).
    from inertest.cli import modulation as cli_modulation
    from inertest.studies import rotation_modulation as rm

    assert cli_modulation._SCHEMES == rm.SCHEMES
