"""`inertest demo`: the example campaign end to end (what `make demo` runs)."""

import re
import tomllib

from inertest.cli import main


def test_demo_prints_truth_vs_estimate_and_writes_report(tmp_path, examples_dir, capsys):
    rep = tmp_path / "inertest-report"
    assert main(["demo", "--examples", str(examples_dir), "--report", str(rep)]) == 0
    captured = capsys.readouterr()
    out = captured.out
    campaign = tomllib.loads((examples_dir / "demo.toml").read_text())["test"]
    for test in campaign:
        assert test["title"] in out
    # issue 30: one progress line per test as it starts (stderr), in the campaign's order
    started = re.findall(r"^\[test (\d+)/(\d+)\] (.+) \.\.\.$", captured.err, flags=re.M)
    assert [(int(k), int(n), t) for k, n, t in started] == [
        (k, len(campaign), t["title"]) for k, t in enumerate(campaign, start=1)]
    # every estimate within 4 sigma of the truth it was simulated from, and about 95 % within 2
    ratios = [float(x) for x in re.findall(r"│\s+([+-]\d+\.\d\d) │\n", out)]
    assert len(ratios) >= 9 + 6 + 10 * (len(campaign) - 2)
    assert max(abs(r) for r in ratios) < 4
    assert sum(abs(r) < 2 for r in ratios) >= 0.85 * len(ratios)
    html = (rep / "index.html").read_text()
    assert html.count("data:image/png;base64,") >= len(campaign)
    for test in campaign:
        assert (rep / f"{test['plan'].split('/')[0]}.csv").exists()
    # [[noise]]: the real PSINS recording, six channels, figures and the Kalibr yaml beside it.
    for entry in tomllib.loads((examples_dir / "demo.toml").read_text()).get("noise", []):
        assert entry["title"] in out and "accel_z" in out
        assert f"{entry['title']}: accel_z: Allan deviation and PSD" in html
        stem = entry["data"].split("/")[-1].split(".")[0]
        assert "gyroscope_noise_density:" in (rep / f"{stem}_imu.yaml").read_text()
    # [[thermal]]: K, M, B laws of a simulated chamber test; the held-out run's drift is removed.
    for entry in tomllib.loads((examples_dir / "demo.toml").read_text()).get("thermal", []):
        assert entry["title"] in out and entry["title"] in html
        assert "drift after [mg]" in html and "not significant" in html
        drift = re.findall(r"output_[xyz]: [\d.]+ / ([\d.]+) -> [\d.]+ / ([\d.]+)", out)
        assert len(drift) == 3
        assert all(float(before) > 1.0 and float(after) < 0.2 for before, after in drift)
        stem = entry["plan"].split("/")[0]
        assert (rep / f"{stem}.csv").exists() and (rep / f"{stem}_held_out.csv").exists()
    # one verdict line per test, after its table; the references are the example truths against
    # the example limits, decided by hand (U is ~0.02 of each tolerance or less):
    verdicts = re.findall(r"^verdict(?: \((.+?)\))?: (.+)$", out, flags=re.M)
    assert len(verdicts) == len(campaign) and all(v for _, v in verdicts)
    by_title = dict(zip([t["title"] for t in campaign], verdicts, strict=True))
    # triad: B_x, B_y, B_z = 12.5, -8.3, 21 mg against |B| <= 5 mg (simple acceptance)
    assert by_title["Accelerometer triad, 12 positions"][1].startswith(
        "fail: worst B_z = 21") and "(3 of 4 limits fail)" in by_title[
        "Accelerometer triad, 12 positions"][1]
    # polar tumble: DI, DO, DS = 0.85, -0.62, 0.31 deg/h/g, inside 1, 1, 0.5 by > 0.15
    assert by_title["Polar-axis tumble"] == ("Example spec, navigation-grade floated gyro",
                                             "pass (3 of 3 limits)")
    # dividing head: KIP = 20 ug/g^2 exactly at its limit of 20: conditional either way
    assert re.match(r"conditional (pass|fail): worst KIP ", by_title[
        "Accelerometer on a dividing head (multipoint)"][1])
    no_spec = [t["title"] for t in campaign if "spec" not in t]
    assert no_spec and all(by_title[t] == ("", "- (no specification)") for t in no_spec)
