"""Site constants against NIMA TR8350.2 (WGS-84) published values."""

import numpy as np
import pytest

from inertest import earth
from inertest.errors import InputError


def test_tr8350_normal_gravity_equator_and_pole():
    # TR8350.2 table 3.4: gamma_e = 9.7803253359, gamma_p = 9.8321849378 m/s^2.
    assert earth.normal_gravity(0.0) == pytest.approx(9.7803253359, abs=1e-10)
    assert earth.normal_gravity(np.pi / 2) == pytest.approx(9.8321849378, abs=2e-10)
    assert earth.normal_gravity(-np.pi / 2) == pytest.approx(9.8321849378, abs=2e-10)


def test_grs80_textbook_series_agrees_within_its_truncation():
    # The textbook GRS80 series 9.780327 (1 + 0.0053024 sin^2 L - 0.0000058 sin^2 2L)
    # (e.g. Moritz, "Geodetic Reference System 1980") agrees with the closed form to ~1e-5 m/s^2.
    lat = np.radians(np.linspace(-90, 90, 37))
    series = 9.780327 * (1 + 0.0053024 * np.sin(lat) ** 2 - 0.0000058 * np.sin(2 * lat) ** 2)
    np.testing.assert_allclose(earth.normal_gravity(lat), series, atol=2e-5)


def test_earth_rate_and_enu_components():
    assert earth.OMEGA_IE == 7.2921151467e-5
    lat = np.radians(34.0)
    w = earth.earth_rate_enu(lat)
    np.testing.assert_allclose(w, [0, 7.2921151467e-5 * np.cos(lat), 7.2921151467e-5 * np.sin(lat)])
    np.testing.assert_allclose(earth.polar_axis_enu(lat), w / earth.OMEGA_IE)


def test_site_defaults_to_normal_gravity_and_rejects_bad_values():
    s = earth.Site.at(45.0)
    # GRS80 normal gravity at 45 deg is 9.806199203 m/s^2 (Moritz 1980); WGS-84's gamma_e is
    # 1.4356e-6 m/s^2 smaller (9.7803253359 vs 9.7803267715), so WGS-84 is lower by about that.
    assert s.gravity_m_s2 == pytest.approx(9.806199203 - 1.43e-6, abs=2e-8)
    with pytest.raises(InputError, match="latitude"):
        earth.Site.at(91.0)
    with pytest.raises(InputError, match="gravity"):
        earth.Site.at(30.0, gravity_m_s2=1.0)
