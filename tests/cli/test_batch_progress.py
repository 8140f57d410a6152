"""``inertest batch`` progress bar on stderr: on with --progress, off with --quiet."""

from pathlib import Path

from inertest.cli import main

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "gyro_rate_table"


def _manifest(tmp_path):
    data = tmp_path / "data.csv"
    assert main(["simulate", str(EXAMPLE / "plan.toml"), "--truth", str(EXAMPLE / "truth.toml"),
                 "-o", str(data)]) == 0
    path = tmp_path / "batch.toml"
    path.write_text(f'[[run]]\nplan = "{(EXAMPLE / "plan.toml").as_posix()}"\n'
                    f'data = "{data.as_posix()}"\n', encoding="utf-8")
    return path


def test_progress_bar_on_stderr_and_quiet_turns_it_off(tmp_path, capsys):
    path = _manifest(tmp_path)
    capsys.readouterr()
    assert main(["batch", str(path), "--no-store", "--progress"]) == 0
    out, err = capsys.readouterr()
    assert "1/1" in err and "1/1" not in out
    assert main(["batch", str(path), "--no-store", "--progress", "--quiet"]) == 0
    assert "1/1" not in capsys.readouterr().err
    # not a terminal (captured): no bar by default
    assert main(["batch", str(path), "--no-store"]) == 0
    assert "1/1" not in capsys.readouterr().err
