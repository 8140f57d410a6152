"""Scenario files and the seed 002 worked example."""

import math
import tomllib

import numpy as np
import pytest

from inertest.earth import normal_gravity
from inertest.errors import InputError
from inertest.ins.scenario import scenario_from_mapping, seed_scenario, time_grid


def test_example_file_is_the_seed_scenario(examples_dir):
    with (examples_dir / "ins_errors" / "source_scenario.toml").open("rb") as fh:
        doc = tomllib.load(fh)
    sc = scenario_from_mapping(doc)
    ref = seed_scenario()
    np.testing.assert_allclose(sc.x0, ref.x0, rtol=1e-15)
    np.testing.assert_allclose(sc.u, ref.u, rtol=1e-15)
    assert sc.site.coriolis is False
    assert sc.site.radius_m == pytest.approx(ref.site.radius_m, rel=1e-15)
    assert (sc.duration_s, sc.step_s) == (86400.0, 10.0)


def test_seed_values_in_si():
    """Values from the source's script: Dx = 0.0001 g, Ex = 0.1 deg/h, L0 = 0.0005 deg,
    Qx0 = 20 arcsec, Qz0 = 5 arcmin, g = 9.8. The source's Ex is a platform drift (+ in its
    phi'), i.e. a gyro output error of -0.1 deg/h in inertest's convention."""
    sc = seed_scenario()
    assert sc.u[0] == pytest.approx(9.8e-4)
    assert sc.u[2] == pytest.approx(-0.1 * math.pi / 180 / 3600)
    assert sc.x0[2] == pytest.approx(0.0005 * math.pi / 180)
    assert sc.x0[4] == pytest.approx(20 / 3600 * math.pi / 180)
    assert sc.x0[6] == pytest.approx(5 / 60 * math.pi / 180)


def test_engineering_units_and_defaults():
    sc = scenario_from_mapping({"site": {"latitude_deg": 45.0},
                                "errors": {"accel_bias_ug": [100, -50],
                                           "initial_position_arcsec": [1.0, 2.0]}})
    assert sc.u[0] == pytest.approx(100e-6 * 9.80665)
    assert sc.x0[3] == pytest.approx(2 / 3600 * math.pi / 180)
    assert sc.site.coriolis is True
    assert sc.site.gravity_m_s2 == normal_gravity(math.pi / 4)  # default: normal gravity


@pytest.mark.parametrize("doc, match", [
    ({"site": {}}, "latitude_deg"),
    ({"site": {"latitude_deg": 90}}, "90"),
    ({"site": {"latitude_deg": 10, "lat": 3}}, "unknown key"),
    ({"site": {"latitude_deg": 10}, "errors": {"gyro_drift_deg_h": [1, 2]}}, "3 numbers"),
    ({"site": {"latitude_deg": 10}, "errors": {"gyro_drift_deg_h": [1, 2, "x"]}}, "number"),
    ({"site": {"latitude_deg": 10}, "errors": {"accel_bias_ug": [1, 2],
                                               "accel_bias_m_s2": [1, 2]}}, "twice"),
    ({"site": {"latitude_deg": 10}, "run": {"hours": 0}}, "duration"),
    ({"site": {"latitude_deg": 10}, "run": {"step_s": -1}}, "step"),
    ({"site": {"latitude_deg": 10, "coriolis": "yes"}}, "coriolis"),
])
def test_bad_scenarios(doc, match):
    with pytest.raises(InputError, match=match):
        scenario_from_mapping(doc)


def test_time_grid():
    t = time_grid(86400, 1.0)
    assert t.size == 86401 and t[-1] == 86400.0
    assert time_grid(10, 3).tolist() == [0, 3, 6, 9]
    with pytest.raises(InputError, match="longer"):
        time_grid(1, 2)
