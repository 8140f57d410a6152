import numpy as np
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
