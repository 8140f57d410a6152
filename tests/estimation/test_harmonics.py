import numpy as np
import pytest

from inertest.errors import IdentifiabilityError
from inertest.estimation.harmonics import harmonic_fit


def test_exact_series_recovered():
    t = np.radians(np.arange(0, 360, 22.5))
    terms = [0.3, -1.2, 0.7, 0.05, -0.4]
    y = terms[0] + terms[1] * np.sin(t) + terms[2] * np.cos(t) + terms[3] * np.sin(2 * t) \
        + terms[4] * np.cos(2 * t)
    hf = harmonic_fit(t, y, sigma=1.0)
    np.testing.assert_allclose(hf.values, terms, atol=1e-14)
    assert hf.names == ("B0", "S1", "C1", "S2", "C2")


def test_equally_spaced_std_is_the_discrete_fourier_closed_form():
    # For n equally spaced angles (n a multiple of 4) the columns are orthogonal:
    # var(B0) = s^2/n, var(Sk) = var(Ck) = 2 s^2/n.
    n, s = 16, 0.5
    t = 2 * np.pi * np.arange(n) / n
    hf = harmonic_fit(t, np.zeros(n), sigma=s)
    np.testing.assert_allclose(hf.std, [s / np.sqrt(n)] + [s * np.sqrt(2 / n)] * 4, rtol=1e-12)
    np.testing.assert_allclose(hf.covariance - np.diag(np.diag(hf.covariance)), 0, atol=1e-15)


def test_too_few_angles():
    with pytest.raises(IdentifiabilityError, match="distinct angle"):
        harmonic_fit(np.radians([0, 90, 180, 270, 360]), np.zeros(5))
