import json

from inertest.cli import main


def test_component_json_and_plot(tmp_path, capsys):
    png = tmp_path / "m.png"
    assert main(["modulation", "component", "--stator-hz", "1,4", "--sample-hz", "400",
                 "--duration-s", "20", "--drift-deg-h", "5,-3", "--json",
                 "--plot", str(png)]) == 0
    out = json.loads(capsys.readouterr().out)
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
