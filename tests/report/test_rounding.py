"""Values rounded to their uncertainty: references are JCGM 100:2008 (GUM) 7.2.2 and 7.2.6."""

import pytest

from inertest.report.rounding import format_column, format_number, round_to_uncertainty


@pytest.mark.parametrize("value, std, expected", [
    # GUM 7.2.6: y = 10.057 62 ohm, u_c = 27 mohm -> y = 10.058 ohm
    (10.05762, 0.027, ("10.058", "0.027")),
    # GUM 7.2.2: m_s = 100.021 47 g with u_c = 0.35 mg
    (100.02147, 0.00035, ("100.02147", "0.00035")),
    # GUM 7.2.6: u = 28.05 kHz is quoted 28 kHz
    (1000.0, 28.05, ("1000", "28")),
    # GUM 7.2.6: u = 10.47 mohm to two significant digits (rounded to nearest: 10)
    (50.0, 10.47, ("50", "10")),
    # the round-off: zero to the rounding prints as zero, without a sign
    (-5.8e-17, 0.061, ("0.000", "0.061")),
    (6.1e-11, 0.061, ("0.000", "0.061")),
    # the std's rounding carries to the next decade: 0.0996 -> 0.10
    (3.14159, 0.0996, ("3.14", "0.10")),
    # a scale factor of order 1 known to 3e-7 relative: all its digits down to the std's second
    (1.2345004612, 3.4e-7, ("1.23450046", "0.00000034")),
    # a value smaller than its std, in scientific notation: its last digit at the std's second
    (-7.04e-8, 1.5e-7, ("-7e-08", "1.5e-07")),
])
def test_gum_rounding(value, std, expected):
    assert round_to_uncertainty(value, std) == expected


def test_without_std_four_significant_digits_and_round_off_zero():
    assert round_to_uncertainty(9.80665, None) == ("9.807", "")
    assert format_number(0.000123456) == "0.0001235"
    assert format_number(1e-17, scale=1.0) == "0"
    assert format_column([1.0, -5.8e-17, 2.5]) == ["1.000", "0", "2.500"]
    assert format_number(-0.0) == "0"
