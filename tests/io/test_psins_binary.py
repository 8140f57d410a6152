"""PSINS binary IMU files (binfile32 / binfile), read by data-file suffix."""

from __future__ import annotations

import numpy as np
import pytest

from inertest.errors import DataError
from inertest.io.data_file import read_table
from inertest.io.psins_binary import COLUMNS, read_psins_binary


def test_the_shipped_demo_input_is_read_as_increments(examples_dir):
    path = examples_dir / "systematic" / "imusysclbt.bin"
    d = read_table(path)
    assert list(d) == list(COLUMNS) and d["t_s"].size == 98200
    # the README's layout: 0.01 s samples, 982 s, rest first (the Earth rate and gravity)
    # (t is float32: its steps near 982 s are quantized to 6e-5 s)
    assert np.median(np.diff(d["t_s"])) == pytest.approx(0.01, rel=1e-2)
    w = np.linalg.norm([d[f"dtheta_{a}"][0] for a in "xyz"]) / 0.01
    f = np.linalg.norm([d[f"dv_{a}"][0] for a in "xyz"]) / 0.01
    # (the gyro biases of the demo, 0.1-0.3 deg/h, are 2 % of the Earth rate)
    assert w == pytest.approx(7.2921e-5, rel=0.05) and f == pytest.approx(9.7965, rel=1e-4)
    raw = np.frombuffer(path.read_bytes(), dtype="<f4").reshape(-1, 7)
    assert np.array_equal(d["dv_z"], raw[:, 5].astype(float))


@pytest.mark.parametrize("dtype", ["<f4", "<f8"])
def test_float32_and_float64_files_are_told_apart(tmp_path, dtype):
    n = 50
    rows = np.column_stack([np.full((n, 6), 1e-3), (np.arange(n) + 1) * 0.005]).astype(dtype)
    p = tmp_path / "x.bin"
    p.write_bytes(rows.tobytes())
    d = read_psins_binary(p)
    np.testing.assert_allclose(d["t_s"], (np.arange(n) + 1) * 0.005, rtol=1e-6)


@pytest.mark.parametrize("content", [b"", b"\x00" * 27, np.arange(14, dtype="<f4").tobytes()[:-4],
                                     np.ones(70, dtype="<f4").tobytes()])
def test_anything_else_is_refused_with_the_fix(tmp_path, content):
    p = tmp_path / "bad.bin"
    p.write_bytes(content)
    with pytest.raises(DataError, match="not a PSINS binary IMU file.*convert it to CSV"):
        read_table(p)
