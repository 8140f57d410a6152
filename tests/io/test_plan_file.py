import pytest

from inertest.errors import PlanError, UnitError
from inertest.io.plan_file import load_plan, load_truth

PLAN = """
[site]
latitude_deg = 45.0
[instrument]
output_unit = "mA"
scale_factor = 10.0
[procedure]
kind = "polar-tumble"
positions = 8
"""


def write(tmp_path, text, name="plan.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_example_plans_load(examples_dir):
    plan = load_plan(examples_dir / "polar_tumble" / "plan.toml")
    assert plan.kind == "polar-tumble" and plan.instrument.scale_factor == 12.5
    assert len(plan.procedure.angles_deg) == 16
    ll = load_plan(examples_dir / "local_level_tumble" / "plan.toml")
    assert ll.kind == "local-level-tumble" and len(ll.procedure.positions) == 12


def test_plan_defaults_and_truth(tmp_path):
    plan = load_plan(write(tmp_path, PLAN))
    assert plan.site.gravity_m_s2 == pytest.approx(9.8061978, abs=1e-6)
    assert plan.procedure.angles_deg == (0, 45, 90, 135, 180, 225, 270, 315)
    assert load_truth(write(tmp_path, "[coefficients]\nDF = 2.0\n", "t.toml")) == {"DF": 2.0}
    with pytest.raises(PlanError, match="DF must be a number"):
        load_truth(write(tmp_path, 'DF = "two"\n', "t2.toml"))


@pytest.mark.parametrize(
    "change, message",
    [
        (("polar-tumble", "spin-test"), 'unknown procedure kind "spin-test"'),
        (('"mA"', '"furlong"'), 'unknown output_unit "furlong"'),
        (("scale_factor = 10.0", ""), "needs \\[instrument\\] scale_factor"),
        (("latitude_deg = 45.0", "latitude_deg = 95.0"), "latitude"),
        (("[site]", "[sight]"), "sight.*did you mean \"site\""),
        (("positions = 8", "positions = 0"), "positions must be positive"),
        (("positions = 8", "mountings = ['O-Up']"), '"O-Up" is not one of O-Np, O-Sp'),
        (("kind = ", "kind == "), "not valid TOML"),
    ],
)
def test_bad_plans_are_named(tmp_path, change, message):
    with pytest.raises((PlanError, UnitError), match=message):
        load_plan(write(tmp_path, PLAN.replace(*change)))
