import math

import pytest

from inertest import units
from inertest.errors import UnitError


def test_deg_per_hour_is_one_arcsecond_per_second():
    # 1 deg/h = 1 arcsec/s = 4.84813681109536e-6 rad/s (pi / 648000).
    assert units.DEG_PER_H_TO_RAD_PER_S == pytest.approx(math.pi / 648000, rel=1e-15)
    assert units.ARCSEC_TO_RAD == pytest.approx(4.84813681109536e-6, rel=1e-14)


def test_g0_is_the_cgpm_standard_gravity():
    assert units.G0 == 9.80665
    assert units.accel_to_si(1.0, "ug") == pytest.approx(9.80665e-6)


def test_rate_round_trip_and_unknown_unit():
    assert units.rate_from_si(units.rate_to_si(3.0, "deg/h"), "deg/h") == pytest.approx(3.0)
    assert units.rate_to_si(1.0, "deg/s") == pytest.approx(math.pi / 180)
    with pytest.raises(UnitError, match='unknown angular-rate unit "deg/min"'):
        units.rate_to_si(1.0, "deg/min")


def test_coefficient_units():
    assert [units.gyro_coefficient_unit(k) for k in (0, 1, 2)] == ["deg/h", "deg/h/g", "deg/h/g^2"]


def test_square_roots_of_noise_densities_convert():
    """IEEE Std 952-1997 Annex C: angle random walk in deg/sqrt(h) = 60 deg/h sqrt(s)."""
    from inertest.units import convert

    assert convert(1.0, "deg/sqrt(h)", "deg/h*sqrt(s)") == pytest.approx(60.0, rel=1e-15)
    assert convert(1.0, "deg/h/sqrt(h)", "deg/h/sqrt(s)") == pytest.approx(1 / 60.0, rel=1e-15)
    with pytest.raises(UnitError):
        convert(1.0, "deg/sqrt(h)", "deg/h")
    with pytest.raises(UnitError, match="sqrt"):
        convert(1.0, "deg/sqrt h", "deg/sqrt(h)")


def test_a_temperature_sensitivity_converts_per_kelvin_and_not_to_a_rate():
    from inertest.units import convert

    assert convert(0.004, "deg/h/degC", "deg/h/K") == 0.004
    assert convert(1.0, "ug/degC^2", "ug/K^2") == 1.0
    with pytest.raises(UnitError):
        convert(0.004, "deg/h/degC", "deg/h")
