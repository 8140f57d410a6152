"""Monte Carlo of rotation modulation on an executor (issue 18): seeds from SeedSequence.spawn,
so a process-pool run equals the serial one bit for bit."""

import math
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from inertest.ins.error_model import InsSite
from inertest.studies import rotation_modulation as rm

SITE = InsSite(math.radians(45.0))


def test_process_pool_equals_serial_bit_for_bit():
    t = np.arange(0.0, 301.0, 1.0)
    s = rm.make_scheme("single-axis", t[-1], rate_rad_s=math.radians(10))
    kw = {"gyro_psd": np.full(3, 1e-12), "accel_psd": np.full(3, 2.5e-9), "runs": 70, "rng": 5}
    serial = rm.monte_carlo_noise(SITE, s, t, **kw)
    with ProcessPoolExecutor(max_workers=2) as pool:
        pooled = rm.monte_carlo_noise(SITE, s, t, executor=pool, **kw)
    np.testing.assert_array_equal(pooled, serial)
    assert serial.shape == (70, 7) and np.all(np.std(serial, axis=0) > 0)
    # realisation i depends on its own seed only: the first 40 of 70 equal a run of 40
    np.testing.assert_array_equal(rm.monte_carlo_noise(SITE, s, t, **dict(kw, runs=40)),
                                  serial[:40])
