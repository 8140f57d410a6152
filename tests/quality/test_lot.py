"""Lot statistics of many units: hand-computed numbers, the latest run per unit, Monte Carlo."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from inertest.errors import InputError
from inertest.quality.conformance import spec_from_mapping
from inertest.quality.lot import lot_statistics

SPEC = spec_from_mapping({"spec": {"name": "lot spec"}, "limit": [
    {"id": "bias", "quantity": "B", "max_abs": 1.0, "unit": "deg/h", "clause": "IEEE 952"},
    {"id": "rep", "quantity": "turn_on_repeatability", "max": 0.3, "unit": "deg/h",
     "clause": "IEEE 952"}]})


def envelope(serial, values, *, kind="turn-on-repeatability", when=None, unit="deg/h"):
    """A result envelope as result.to_dict() writes it: serial, coefficients."""
    doc = {"kind": kind, "schema_version": 2, "instrument": {"serial": serial},
           "identification": {"coefficients": {
               k: {"value": v, "std": s, "unit": unit} for k, (v, s) in values.items()},
               "combinations": []}}
    if when is not None:
        doc["test"] = {"tested_at": when}
    return doc


def test_lot_numbers_against_hand_computed_ones():
    x = np.array([0.31, 0.42, 0.28, 0.37, 0.45, 0.33])
    u = np.full(6, 0.02)
    docs = [envelope(f"S{i}", {"B": (x[i], u[i])}) for i in range(6)]
    lot = lot_statistics(docs, SPEC)
    q = lot.quantity("B")
    s = np.std(x, ddof=1)
    assert q.n == 6 and q.mean == pytest.approx(x.mean()) and q.observed_std == pytest.approx(s)
    assert q.observed_interval == pytest.approx(
        (s * np.sqrt(5 / stats.chi2.ppf(0.975, 5)), s * np.sqrt(5 / stats.chi2.ppf(0.025, 5))))
    # equal measurement stds: the REML unit-to-unit variance is s^2 - u^2 (balanced case)
    assert q.unit_to_unit == pytest.approx(np.sqrt(s**2 - 0.02**2), rel=1e-5)
    (cap,) = q.capability
    assert cap.lower == -1.0 and cap.upper == 1.0
    assert cap.cp == pytest.approx(2.0 / (6 * s))
    assert cap.cpk == pytest.approx((1.0 - x.mean()) / (3 * s))
    half = 1.959964 * np.sqrt(1 / 54 + cap.cpk**2 / 10)
    assert cap.cpk_interval == pytest.approx((cap.cpk - half, cap.cpk + half), rel=1e-5)
    assert cap.cp_interval[0] == pytest.approx(cap.cp * np.sqrt(stats.chi2.ppf(0.025, 5) / 5))
    assert cap.cpk_process == pytest.approx((1.0 - x.mean()) / (3 * q.unit_to_unit))
    # its lower bound: at the upper end of the unit-to-unit std's interval
    assert cap.cpk_process_lower == pytest.approx(
        (1.0 - x.mean()) / (3 * q.unit_to_unit_interval[1]))
    assert cap.cpk_process_lower < cap.cpk_process
    assert cap.outside == 0 and not q.stand_out
    assert lot.to_dict()["quantities"][0]["capability"][0]["clause"] == "bias"


def test_a_unit_far_from_the_others_stands_out_and_the_latest_run_counts():
    rng = np.random.default_rng(1)
    docs = [envelope(f"S{i:02d}", {"B": (0.3 + 0.05 * rng.normal(), 0.01)}) for i in range(12)]
    docs.append(envelope("S99", {"B": (1.3, 0.01)}, when="2026-01-01T00:00:00+00:00"))
    docs.append(envelope("S99", {"B": (1.35, 0.01)}, when="2026-02-01T00:00:00+00:00"))
    docs.append(envelope("S99", {"B": (0.3, 0.01)}, when="2025-12-01T00:00:00+00:00"))
    lot = lot_statistics(docs, SPEC)
    q = lot.quantity("B")
    assert q.n == 13 and [s.serial for s in q.stand_out] == ["S99"]
    assert q.stand_out[0].value == 1.35           # the latest run of S99
    assert q.capability[0].outside == 1
    assert any("2 earlier run" in n for n in lot.notes)


def test_quantities_of_different_procedures_stay_apart_and_units_convert():
    docs = [envelope("A", {"B": (0.3, 0.01)}), envelope("B", {"B": (0.35, 0.01)}),
            envelope("A", {"B": (1.0, 0.1)}, kind="in-run-stability"),
            envelope("B", {"B": (0.0003, 0.0001)}, kind="in-run-stability", unit="deg/s")]
    lot = lot_statistics(docs)
    assert {(q.procedure, q.quantity) for q in lot.quantities} == {
        ("turn-on-repeatability", "B"), ("in-run-stability", "B")}
    q = lot.quantity("B", "in-run-stability")
    assert sorted(v.value for v in q.values) == pytest.approx([1.0, 1.08])


def test_envelopes_without_a_serial_or_nothing_at_all_are_refused():
    with pytest.raises(InputError, match="serial"):
        lot_statistics([{"kind": "x", "instrument": {}, "identification": {}}])
    with pytest.raises(InputError, match="at least one unit"):
        lot_statistics([])


@pytest.mark.slow
def test_monte_carlo_cpk_interval_coverage_stand_out_rate_and_measurement_removed():
    """Normal lots of 20 units (unit-to-unit std 0.1, each measured with std 0.1): the Cpk
    interval covers the true Cpk of the observed spread in about 95 % of lots, a good lot
    flags a unit at most at the stated 1 %, and the unit-to-unit std with the measurement
    removed is unbiased in variance while the observed one is not."""
    rng = np.random.default_rng(7)
    n, tau, m = 20, 0.1, 0.1
    sigma_obs = np.hypot(tau, m)
    true_cpk = (1.0 - 0.3) / (3 * sigma_obs)
    cover = flagged = 0
    tau2, s2 = [], []
    lots = 400
    for _ in range(lots):
        x = 0.3 + tau * rng.normal(size=n) + m * rng.normal(size=n)
        q = lot_statistics([envelope(f"S{i}", {"B": (x[i], m)}) for i in range(n)],
                           SPEC).quantity("B")
        lo, hi = q.capability[0].cpk_interval
        cover += lo <= true_cpk <= hi
        flagged += bool(q.stand_out)
        tau2.append(q.unit_to_unit**2)
        s2.append(q.observed_std**2)
    print(f"lot MC: Cpk interval coverage {cover / lots:.3f}, lots flagged {flagged / lots:.3f}")
    assert abs(cover / lots - 0.95) < 3 * np.sqrt(0.05 * 0.95 / lots) + 0.01
    assert flagged / lots <= 0.01 + 3 * np.sqrt(0.01 * 0.99 / lots)
    assert np.mean(tau2) == pytest.approx(tau**2, rel=0.15)
    assert np.mean(s2) == pytest.approx(tau**2 + m**2, rel=0.1)
