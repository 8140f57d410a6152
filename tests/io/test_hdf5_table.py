"""HDF5 tables: round trip of numeric and text columns, units as attributes, atomic write."""

import h5py
import numpy as np
import pytest

from inertest.errors import DataError
from inertest.io.data_file import read_table, write_table
from inertest.io.hdf5_table import read_hdf5_table


def test_round_trip_with_units(tmp_path):
    p = tmp_path / "t.h5"
    cols = {"part": np.array(["x_p", "x_a"]), "acc_x": np.array([1.5, -2.0])}
    write_table(p, cols, {"acc_x": "m/s^2"})
    back = read_hdf5_table(p)
    assert back["part"].tolist() == ["x_p", "x_a"]
    np.testing.assert_array_equal(back["acc_x"], cols["acc_x"])
    with h5py.File(p) as fh:
        assert fh["acc_x"].attrs["unit"] == "m/s^2"
    csv = tmp_path / "t.csv"
    write_table(csv, cols)
    assert read_table(csv)["part"].tolist() == ["x_p", "x_a"]


def test_not_hdf5_is_a_clear_error(tmp_path):
    p = tmp_path / "bad.h5"
    p.write_text("not hdf5")
    with pytest.raises(DataError, match="cannot be read as HDF5"):
        read_hdf5_table(p)


@pytest.mark.parametrize("data, what", [
    (np.array([1 + 2j, 3 - 1j]), "complex numbers"),
    (np.array([(1.0, 2), (3.0, 4)], dtype=[("a", "f8"), ("b", "i4")]), ".*not one real number"),
])
def test_a_column_that_is_not_real_is_refused_with_its_name(tmp_path, data, what):
    """Issue 34: a complex column was read with its imaginary part silently dropped."""
    p = tmp_path / "c.h5"
    with h5py.File(p, "w") as fh:
        fh["good"] = np.ones(2)
        fh["rate"] = data
    with pytest.raises(DataError, match=f"column 'rate' holds {what}"):
        read_table(p)


def test_a_variable_length_array_column_is_refused_with_its_name(tmp_path):
    p = tmp_path / "v.h5"
    with h5py.File(p, "w") as fh:
        ds = fh.create_dataset("rate", (2,), dtype=h5py.vlen_dtype(np.float64))
        ds[0], ds[1] = np.ones(3), np.ones(2)
    with pytest.raises(DataError, match="column 'rate' holds object values"):
        read_table(p)


def test_boolean_and_integer_columns_are_numbers(tmp_path):
    p = tmp_path / "b.h5"
    with h5py.File(p, "w") as fh:
        fh["flag"] = np.array([True, False])
        fh["count"] = np.array([3, -4], dtype=np.int16)
    back = read_table(p)
    assert back["flag"].tolist() == [1.0, 0.0] and back["count"].tolist() == [3.0, -4.0]
