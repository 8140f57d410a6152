"""`inertest demo`: the example campaign end to end (what `make demo` runs)."""

import re

from inertest.cli import main


def test_demo_prints_truth_vs_estimate_and_writes_report(tmp_path, examples_dir, capsys):
    rep = tmp_path / "inertest-report"
    assert main(["demo", "--examples", str(examples_dir), "--report", str(rep)]) == 0
    out = capsys.readouterr().out
    assert "Polar-axis tumble" in out and "Local-level tumble" in out
    # every estimate within 4 sigma of the truth it was simulated from
    ratios = [float(x) for x in re.findall(r"│\s+([+-]\d+\.\d\d) │\n", out)]
    assert len(ratios) == 9 + 6
    assert max(abs(r) for r in ratios) < 4
    html = (rep / "index.html").read_text()
    assert html.count("data:image/png;base64,") == 2
    assert (rep / "polar_tumble.csv").exists()
