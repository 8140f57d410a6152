import numpy as np
import pyarrow as pa
import pytest

from inertest.errors import DataError
from inertest.io.data_file import read_table, write_table


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_round_trip(tmp_path, suffix):
    cols = {"mounting": np.array(["O-Np", "S-Sp"]), "angle_deg": np.array([0.0, 22.5]),
            "output": np.array([0.123456789012345, -1e-9])}
    p = write_table(tmp_path / f"d{suffix}", cols)
    back = read_table(p)
    assert back["mounting"].tolist() == ["O-Np", "S-Sp"]
    np.testing.assert_array_equal(back["output"], cols["output"])


def test_empty_cells_become_nan_and_unknown_suffix(tmp_path):
    p = tmp_path / "d.csv"
    p.write_text("angle_deg,output\n0,1.0\n90,\n")
    assert np.isnan(read_table(p)["output"][1])
    with pytest.raises(DataError, match="use .csv, .parquet or .h5"):
        read_table(tmp_path / "d.xlsx")


@pytest.mark.parametrize("distinct", [3, 70_000])
def test_text_columns_match_the_csv_module(tmp_path, distinct):
    # Text columns of few labels (encoded while parsing) and of many (plain strings) read as
    # Python's own csv module reads them; empty cells are "", numbers stay exact.
    import csv

    rng = np.random.default_rng(0)
    n = 140_000
    labels = np.array([f"L{k}" for k in range(distinct)] + [""])
    text = labels[rng.integers(0, labels.size, n)]
    values = rng.normal(size=n)
    p = tmp_path / "d.csv"
    with p.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["label", "value", "count"])
        w.writerows(zip(text, map(repr, values.tolist()), range(n), strict=True))
    with p.open(newline="") as fh:
        rows = list(csv.reader(fh))[1:]
    back = read_table(p)
    assert back["label"].tolist() == [r[0] for r in rows]
    np.testing.assert_array_equal(back["value"], [float(r[1]) for r in rows])
    assert back["count"].dtype == np.float64
    np.testing.assert_array_equal(back["count"], np.arange(n))


def test_parquet_text_nulls_become_empty(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    p = tmp_path / "d.parquet"
    pq.write_table(pa.table({"m": pa.array(["a", None, "b", "a"])}), p)
    assert read_table(p)["m"].tolist() == ["a", "", "b", "a"]
    pq.write_table(pa.table({"m": pa.array(["a", None, "b"]).dictionary_encode()}), p)
    assert read_table(p)["m"].tolist() == ["a", "", "b"]


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_columns_are_writable(tmp_path, suffix):
    p = write_table(tmp_path / f"d{suffix}", {"a": np.arange(3.0), "b": np.arange(3)})
    back = read_table(p)
    back["a"][0] = np.nan
    back["b"][0] = 7.0


def test_columns_from_arrow_buffers_equal_to_numpy_and_load_no_pandas(tmp_path):
    # Columns read from the Arrow buffers (chunks, offsets, nulls, ints, float32, dictionary
    # text with nulls) equal Arrow's own to_numpy, which imports pandas; read_table does not.
    import subprocess
    import sys

    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.table({
        "i": pa.chunked_array([pa.array([1, None, 3], pa.int32()),
                               pa.array([2**60 + 1, -5], pa.int64()).cast(pa.int32(), safe=False)]),
        "big": pa.array([2**60 + 1, None, 7, -(2**53) - 1, 0], pa.int64()),
        "f": pa.chunked_array([pa.array([1.5, None], pa.float32()),
                               pa.array([None, 2.25, 1e-3], pa.float32())]),
        "d": pa.array([0.1, 0.2, None, 0.4, 0.5]),
        "s": pa.array(["x", None, "y", "x", "z"]).dictionary_encode(),
    })
    p = tmp_path / "d.parquet"
    pq.write_table(table, p, row_group_size=2)
    back = read_table(p)
    ref = pq.read_table(p)
    for name in ("i", "big", "f", "d"):
        want = ref.column(name).to_numpy(zero_copy_only=False).astype(float)
        np.testing.assert_array_equal(back[name], want)
    assert back["s"].tolist() == ["x", "", "y", "x", "z"]
    code = ("import sys\nfrom inertest.io.data_file import read_table\n"
            f"read_table({str(p)!r})\nread_table({str(p.with_suffix('.csv'))!r})\n"
            "print('pandas' in sys.modules)")
    write_table(p.with_suffix(".csv"), {"m": np.array(["a", "b"]), "v": np.array([1.0, 2.0])})
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == ["False"]


@pytest.mark.parametrize("text", [
    "a,b\n" + "0,x\n" * 50 + "22.5,y\n",          # ints first, then a float
    "a,b\n" + ",x\n" * 50 + "3,y\n",              # empty first, then a number
    "a,b\n" + "1,x\n" * 50 + "abc,y\n",           # numbers first, then text
    "a,b\n" + "1,\n" * 50 + "1,y\n",              # empty text first
    "a,b\n" + "".join(f"{2**60 + i},L{i % 3}\n" for i in range(300)),
    "a,b\n" + "".join(f"{i * 0.1!r},L{i}\n" for i in range(300)),
    'a,b\n' + '"x,1",2\n' * 40 + '"y\nz",\n',
    "a,b\ntrue,2024-01-01\n" * 40,
    "a,b\n",
    # Long rows first, then short: the columns sized from the first block must grow (often).
    "a,b\n" + "".join(f"{0.1 * i!r}12345678901,L{i % 2}\n" for i in range(3))
    + "".join(f"{i},M{i % 5}\n" for i in range(400)),
    # Short rows first, then long: sized too large, the unused tail never read.
    "a,b\n" + "".join(f"{i},x\n" for i in range(40))
    + "".join(f"{i * 0.1!r}9876543210123,y{i % 7}\n" for i in range(100)),
])
def test_csv_read_in_blocks_equals_the_whole_file(tmp_path, monkeypatch, text):
    # The streaming read (blocks of 64 bytes here) gives the columns of the whole-file read,
    # or hands over to it (types that change after the first block, empty files).
    from inertest.io import data_file

    p = tmp_path / "d.csv"
    p.write_text(text)
    monkeypatch.setattr(data_file, "_CSV_BLOCK_BYTES", 64)
    monkeypatch.setattr(data_file, "_CSV_WHOLE_BYTES", 0)  # small files are read whole
    blocks = read_table(p)
    monkeypatch.setattr(data_file, "_read_csv_blocks", lambda path: None)
    whole = read_table(p)
    assert list(blocks) == list(whole)
    for name, col in whole.items():
        assert blocks[name].dtype == col.dtype
        np.testing.assert_array_equal(blocks[name], col)


@pytest.mark.parametrize("text", [
    "a,b,c\n" + "".join(f"{i},{2**60 + 7 * i},{i * 0.5!r}\n" for i in range(300)),
    "a,b\n" + "".join(f"{-(2**63) + 1 + i},L{i % 3}\n" for i in range(50)),
    "a,b\n" + "0,x\n" * 50 + "22.5,y\n",
])
def test_small_csv_integer_columns_read_whole_equal_the_reparsed_ones(
        tmp_path, monkeypatch, text):
    # A small file is read whole and its integer columns cast to float64; the block reader
    # parses integers as float64 from the start. The numbers must agree with each other (each
    # integer rounded to the nearest double) and with Python's float().
    from inertest.io import data_file

    p = tmp_path / "d.csv"
    p.write_text(text)
    one = read_table(p)
    monkeypatch.setattr(data_file, "_CSV_BLOCK_BYTES", 64)  # several blocks: parsed again
    monkeypatch.setattr(data_file, "_CSV_WHOLE_BYTES", 0)
    again = read_table(p)
    rows = [line.split(",") for line in text.strip().splitlines()[1:]]
    for j, name in enumerate(one):
        assert one[name].dtype == again[name].dtype
        np.testing.assert_array_equal(one[name], again[name])
        if one[name].dtype == np.float64:
            np.testing.assert_array_equal(one[name], [float(r[j]) for r in rows])


@pytest.mark.parametrize("column, kind", [
    (pa.array([[1.0, 2.0], [3.0]]), "list<"),
    (pa.array([{"x": 1.0}, {"x": 2.0}]), "struct<"),
])
def test_a_parquet_list_or_record_column_is_refused_with_its_name(tmp_path, column, kind):
    """Issue 34: a Parquet list column ended in an internal error (unsupported cast)."""
    import pyarrow.parquet as pq

    p = tmp_path / "l.parquet"
    pq.write_table(pa.table({"t": [0.0, 1.0], "gyro": column}), p)
    with pytest.raises(DataError, match=f"column 'gyro' holds {kind}.*own"):
        read_table(p)


def test_a_complex_npy_is_refused(tmp_path):
    from inertest.io.raw_samples import read_samples

    np.save(tmp_path / "c.npy", np.ones(4) + 1j)
    with pytest.raises(DataError, match="complex numbers"):
        read_samples(tmp_path / "c.npy")
