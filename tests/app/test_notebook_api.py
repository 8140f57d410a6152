"""Notebook users (issue 30): fit, run and load_data take DataFrames, pyarrow Tables and dicts;
results as DataFrames; errors in the API's words in the API and the CLI's in the CLI."""

from __future__ import annotations

import numpy as np
import pytest

import inertest
from inertest.app.run import DuplicateRunError
from inertest.cli import main
from inertest.errors import InputError, MissingExtraError, import_extra
from inertest.io.data_file import read_table, write_table

pd = pytest.importorskip("pandas")
pa = pytest.importorskip("pyarrow")


@pytest.fixture(scope="module")
def tumble(tmp_path_factory):
    d = tmp_path_factory.mktemp("tumble")
    plan = inertest.load_plan(
        __import__("pathlib").Path(__file__).resolve().parents[2] / "examples" / "polar_tumble"
        / "plan.toml")
    data = inertest.simulate(plan, {"DF": 1.2, "DI": 0.85, "DO": -0.6, "DS": 0.3}, noise=0.002,
                             rng=4)
    write_table(d / "data.csv", data)
    return plan, d / "data.csv"


def test_a_dataframe_a_table_and_a_dict_fit_as_the_file_does(tumble):
    plan, path = tumble
    ref = inertest.fit(plan, path)
    frame = pd.read_csv(path)
    for data in (frame, pa.Table.from_pandas(frame), read_table(path),
                 {k: frame[k].to_numpy() for k in frame}):
        got = inertest.fit(plan, data)
        for k, e in ref.coefficients.items():
            assert got.coefficients[k].value == pytest.approx(e.value, rel=1e-12, abs=1e-12)
            assert got.coefficients[k].std == pytest.approx(e.std, rel=1e-12)
    cols = inertest.load_data(frame)
    assert list(cols) == list(frame) and cols["angle_deg"].dtype == frame["angle_deg"].dtype
    out = inertest.run(plan, frame)
    assert out.result.coefficients["DI"].value == pytest.approx(
        ref.coefficients["DI"].value, rel=1e-12)


def test_results_as_dataframes_with_units_and_a_named_covariance(tumble):
    plan, path = tumble
    res = inertest.fit(plan, path)
    table = res.to_pandas()
    assert list(table.columns) == ["kind", "value", "std", "unit", "terms"]
    for name, e in res.coefficients.items():
        assert table.loc[name, "value"] == e.value and table.loc[name, "unit"] == e.unit
        assert table.loc[name, "kind"] == "coefficient"
    for c in res.combinations:
        assert table.loc[c.name, "std"] == c.std and table.loc[c.name, "kind"] == "combination"
    cov = res.covariance_to_pandas()
    names = list(res.identification.names)
    assert list(cov.index) == names and list(cov.columns) == names
    assert cov.loc["DI", "DI"] == pytest.approx(res.coefficients["DI"].std ** 2, rel=1e-9)
    assert cov.attrs["units"]["DI"] == res.coefficients["DI"].unit
    assert inertest.run(plan, path).to_pandas().equals(table)


def test_what_is_not_data_is_named_in_the_apis_words(tumble):
    plan, _ = tumble
    with pytest.raises(InputError, match="must be a path to a data file, a pandas DataFrame, a "
                                         "pyarrow Table or a dict of column arrays; got int"):
        inertest.fit(plan, 42)
    with pytest.raises(InputError, match="topic and layout are for data files"):
        inertest.load_data({"a": [1.0]}, topic="/imu")


def test_a_duplicate_run_speaks_the_api_in_python_and_the_options_on_the_command_line(
        tumble, tmp_path, capsys):
    plan, path = tumble
    db = tmp_path / "h.db"
    inertest.run(plan, path, store=str(db))
    with pytest.raises(DuplicateRunError) as err:
        inertest.run(plan, path, store=str(db))
    assert "Pass allow_duplicate=True to file it again, or store=False" in str(err.value)
    assert "--" not in str(err.value)
    plan_file = tmp_path / "plan.toml"
    plan_file.write_text((__import__("pathlib").Path(__file__).resolve().parents[2] / "examples"
                          / "polar_tumble" / "plan.toml").read_text())
    assert main(["fit", str(plan_file), str(path), "--db", str(db)]) == 2
    line = capsys.readouterr().err.strip()
    assert line.endswith("Use --allow-duplicate to file it again, or --no-store")
    assert "allow_duplicate=True" not in line


def test_a_missing_extra_is_one_line_naming_its_install(monkeypatch, tmp_path, capsys):
    import sys

    for name in ("rosbags", "pyulog"):  # as if not installed: the import raises ImportError
        monkeypatch.setitem(sys.modules, name, None)
    with pytest.raises(MissingExtraError, match=r"pip install 'inertest\[ros\]'"):
        import_extra("rosbags", "reading ROS bags")
    bag = tmp_path / "x.bag"
    bag.write_bytes(b"#ROSBAG V2.0\n")
    (tmp_path / "x.ulg").write_bytes(b"ULog")
    for f, extra in ((bag, "ros"), (tmp_path / "x.ulg", "px4")):
        assert main(["noise", str(f)]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and f"pip install 'inertest[{extra}]'" in err, err


def test_load_data_reads_bags_by_topic_and_tables_by_path(tmp_path):
    path = tmp_path / "t.csv"
    write_table(path, {"a": np.arange(3.0)})
    assert list(inertest.load_data(path)) == ["a"]
    with pytest.raises(InputError, match="a table has no topics; drop --topic"):
        inertest.load_data(path, topic="/imu")
