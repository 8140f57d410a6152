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
