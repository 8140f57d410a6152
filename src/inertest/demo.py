"""The example campaign run by ``inertest demo``: simulate, fit and report each listed test.

The campaign file ``examples/demo.toml`` lists the tests::

    [[test]]
    title = "Polar-axis tumble"
    plan = "polar_tumble/plan.toml"     # relative to the campaign file
    truth = "truth.toml"
    noise = 0.002                        # per reading, in the plan's output unit
    seed = 1
    spec = "specs/floated_gyro.toml"     # optional: verdicts against this specification

With a top-level ``equipment`` lab file every result also gets its uncertainty budget
(:func:`inertest.app.run.judge`), shown beside the verdicts.

An ``[[acceptance]]`` entry runs an acceptance campaign (``campaign``: a manifest, see
:mod:`inertest.app.acceptance`) on its shipped data, and with ``lot = N`` also simulates a lot of
N units of the same type (:func:`lot_truths`: each unit's coefficients drawn around the shipped
unit's, one planted to stand out), fits their tests and writes the lot report
(:mod:`inertest.quality.lot`).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from inertest.api import fit, load_plan, simulate
from inertest.app.run import columns_sha256, judge
from inertest.errors import PlanError
from inertest.io.atomic import target_directory
from inertest.io.data_file import write_table
from inertest.io.plan_file import read_toml
from inertest.models.sdf_gyro import COEFFICIENTS
from inertest.procedures import procedure
from inertest.quality.conformance import read_spec
from inertest.quality.lab import (
    identity_block,
    read_equipment,
    read_laboratory,
    select_equipment,
    test_time,
)
from inertest.report.conformance import conformance_sections
from inertest.report.html import Section, page, paragraph, software_version
from inertest.report.identity import identity_section
from inertest.report.sections import result_sections
from inertest.results import with_blocks


@dataclass(frozen=True)
class DemoTest:
    """One simulated test of the campaign and its fit."""

    title: str
    plan_path: Path
    truth_deg_h: dict[str, float]
    noise: float
    seed: int
    data: dict[str, Any]
    result: Any
    test: dict[str, Any] | None = None
    budget: Any = None
    conformance: Any = None

    def to_dict(self) -> dict[str, object]:
        """The result envelope with its ``test`` block, uncertainty budget and verdicts."""
        return with_blocks(
            self.result.to_dict(), test=self.test,
            uncertainty_budget=None if self.budget is None else self.budget.to_dict(),
            conformance=None if self.conformance is None else self.conformance.to_dict())


@dataclass(frozen=True)
class DemoThermal:
    """A simulated chamber test of a triad, its K, M, B laws and a held-out run corrected.

    ``before_mg`` / ``after_mg``: per axis, the RMS error of the corrected specific force [mg]
    and its drift (largest minus smallest step mean) [mg] over the held-out run, with the
    calibration at T_ref only (before) and with the laws at each row's temperature (after).
    """

    title: str
    plan_path: Path
    noise: float
    seed: int
    data: dict[str, Any]
    held_out: dict[str, Any]
    result: Any
    before_mg: dict[str, tuple[float, float]]
    after_mg: dict[str, tuple[float, float]]


def run_thermal(campaign: str | os.PathLike[str], *,
                progress: Started | None = None) -> list[DemoThermal]:
    """Simulate, fit and apply every ``[[thermal]]`` test of the campaign file."""
    from inertest.equipment.multiposition import motion
    from inertest.procedures.thermal_triad import fit_triad_thermal, simulate_triad_thermal
    from inertest.units import MILLI_G_TO_M_PER_S2

    cpath = Path(campaign)
    out = []
    entries = read_toml(cpath, "campaign").get("thermal", [])
    for k, t in enumerate(entries, start=1):
        _started(progress, k, len(entries), str(t.get("title", "thermal triad")))
        plan_path = cpath.parent / t["plan"]
        laws_doc = read_toml(plan_path.parent / t.get("laws", "laws.toml"), "laws")
        plan = load_plan(plan_path)
        noise, seed = float(t.get("noise", 0.0)), int(t.get("seed", 0))
        t_ref = float(laws_doc["t_ref_c"])
        laws = laws_doc["laws"]
        data = simulate_triad_thermal(plan, laws, t_ref_c=t_ref,
                                      temperatures_c=np.arange(-40.0, 61.0, 10.0),
                                      noise=noise, rng=seed)
        result = fit_triad_thermal(plan, data, degree=2, t_ref_c=t_ref)
        model = result.model()
        held = simulate_triad_thermal(plan, laws, t_ref_c=t_ref,
                                      temperatures_c=np.arange(-35.0, 56.0, 10.0),
                                      branches=("heating",), noise=noise, rng=seed + 1000)
        raw = np.column_stack([held[f"output_{a}"] for a in "xyz"])
        temp = np.asarray(held["temperature_c"], dtype=float)
        f = motion(held["position"], plan.site).inputs_of_rows(held["position"]).f_i
        quality = []
        for at in (np.full(temp.size, t_ref), temp):
            err = (model.compensate(raw, at)[0] - f) / MILLI_G_TO_M_PER_S2
            means = np.array([err[temp == T].mean(axis=0) for T in np.unique(temp)])
            quality.append({a: (float(np.sqrt(np.mean(err[:, i] ** 2))),
                                float(np.ptp(means[:, i]))) for i, a in enumerate("xyz")})
        out.append(DemoThermal(str(t.get("title", "thermal triad")), plan_path, noise, seed,
                               data, held, result, quality[0], quality[1]))
    return out


def thermal_sections(t: DemoThermal) -> list[Section]:
    """Report sections of one thermal test: the laws, and the held-out run before/after."""
    from inertest.report.html import table_html
    from inertest.report.thermal import triad_thermal_sections

    secs = triad_thermal_sections(t.result, title=t.title)
    rows = [[f"output_{a}", f"{t.before_mg[a][0]:.3f}", f"{t.after_mg[a][0]:.3f}",
             f"{t.before_mg[a][1]:.3f}", f"{t.after_mg[a][1]:.3f}"] for a in "xyz"]
    secs[0].parts.append(paragraph(
        f"Held-out heating run at temperatures between the steps (-35 to 55 degC, file "
        f"{t.plan_path.parent.name}_held_out.csv), corrected by the model as inertest apply "
        "does: before = the calibration at T_ref only, after = K, M, B at each row's "
        "temperature. Error = corrected minus true specific force."))
    secs[0].parts.append(table_html(
        ["axis", "RMS error before [mg]", "RMS error after [mg]", "drift before [mg]",
         "drift after [mg]"], rows,
        caption="Held-out run: drift = largest minus smallest step mean of the error"))
    return secs


def find_examples(start: Path | None = None) -> Path:
    """The ``examples`` folder: in the current directory, or beside the source checkout."""
    here = Path(start) if start is not None else Path.cwd()
    for cand in (here / "examples", Path(__file__).resolve().parents[2] / "examples"):
        if (cand / "demo.toml").is_file():
            return cand
    raise PlanError(
        "cannot find examples/demo.toml; run `inertest demo` from the inertest checkout "
        "or give --examples DIR"
    )


#: ``progress(k, n, title)``, called as the k-th of n entries starts (one line per test).
Started = Callable[[int, int, str], None]


def _started(progress: Started | None, k: int, n: int, title: str) -> None:
    if progress is not None:
        progress(k, n, title)


def run_campaign(campaign: str | os.PathLike[str], *,
                 progress: Started | None = None) -> list[DemoTest]:
    """Simulate and fit every test listed in the campaign file (``progress`` per test)."""
    cpath = Path(campaign)
    doc = read_toml(cpath, "campaign")
    tests = doc.get("test")
    if not isinstance(tests, list) or not tests:
        raise PlanError(f"campaign {cpath} lists no [[test]] entries")
    lab_file = doc.get("equipment")
    lab = read_equipment(cpath.parent / str(lab_file)) if lab_file is not None else None
    laboratory = read_laboratory(cpath.parent / str(lab_file)) if lab_file is not None else None
    version = software_version()
    out = []
    for k, t in enumerate(tests, start=1):
        _started(progress, k, len(tests), str(t.get("title", t.get("plan", ""))))
        plan_path = cpath.parent / t["plan"]
        truth_path = plan_path.parent / t.get("truth", "truth.toml")
        truth_doc = read_toml(truth_path, "truth")
        truth = {k: float(v) for k, v in truth_doc.get("coefficients", truth_doc).items()}
        plan = load_plan(plan_path)
        noise, seed = float(t.get("noise", 0.0)), int(t.get("seed", 0))
        data = simulate(plan, truth, noise=noise, rng=seed)
        result = fit(plan, data)
        truth = procedure(plan.kind).truth_quantities(truth)
        block = identity_block(
            plan.test, lab=lab, tested=test_time(plan.test), software_version=version,
            data_sha256=columns_sha256(data), plan_source=f"plan {plan_path}",
            lab_source=f"lab file {cpath.parent / str(lab_file)}", laboratory=laboratory)
        spec = read_spec(cpath.parent / str(t["spec"])) if t.get("spec") else None
        budget = conformance = None
        if lab is not None or spec is not None:
            used = (select_equipment(lab, plan.test.equipment, plan_source=f"plan {plan_path}",
                                     lab_source=f"lab file {cpath.parent / str(lab_file)}")
                    if lab is not None and plan.test is not None else ())
            budget, conformance = judge(plan, result, used, spec)
        out.append(DemoTest(str(t.get("title", plan.kind)), plan_path, truth, noise, seed,
                            data, result, block, budget, conformance))
    return out


def write_campaign_report(tests: list[DemoTest], directory: str | os.PathLike[str], *,
                          noise: list[DemoNoise] | None = None,
                          thermal: list[DemoThermal] | None = None,
                          acceptance: list[DemoAcceptance] | None = None,
                          command: str = "inertest demo") -> Path:
    """Write ``index.html`` (self-contained) and the simulated data files into ``directory``.

    ``command`` is the command line that ran the campaign (stated in the report's identity).

    ``noise`` (from :func:`run_noise`) adds its report sections after the tests and writes each
    recording's Kalibr ``<name>_imu.yaml`` beside the report. ``thermal`` (from
    :func:`run_thermal`) adds the laws, hysteresis and held-out run of each thermal test and
    writes its chamber and held-out data.
    """
    sections = [Section("About this report", [paragraph(
        "Simulated campaign on virtual instruments: each test below was simulated from the true "
        "coefficients shown, with noise, and then fitted as measured data would be. "
        "'error/std' is (estimate − truth) / std: with honest uncertainties about 95 % of the "
        "values lie within ±2. Floated-gyro drift coefficients (" + ", ".join(COEFFICIENTS)
        + ") are in deg/h, deg/h/g, deg/h/g^2 (g = 9.80665 m/s^2); every other quantity carries "
        "its unit in its row.")])]
    for t in tests:
        parts = result_sections(t.result, t.truth_deg_h, title=t.title)
        ident = identity_section(f"{t.title}: identity", t.to_dict(), extra_rows=[
            ["plan", str(t.plan_path.name)], ["data", f"{t.plan_path.parent.name}.csv "
             f"(simulated, noise {t.noise:g} per reading, seed {t.seed})"]])
        sections += [ident, *parts, *conformance_sections(
            t.to_dict(), title=f"{t.title}: conformance and uncertainty budget")]
    sections += noise_sections(noise or [])
    for th in thermal or ():
        sections += thermal_sections(th)
    sections += acceptance_sections(acceptance or [])
    per_test = "one per test, in its identity table below"
    html = page("inertest: example test campaign", sections,
                identity=[["command", command], ["input", "simulated from the "
                           "examples' plans and truths (seeds in each test's identity)"],
                          ["serial", per_test], ["site", per_test], ["operator", per_test]],
                subtitle=f"Generated by `inertest demo` on {datetime.now(UTC):%Y-%m-%d %H:%M} "
                         f"UTC with inertest {software_version()}.")
    with target_directory(directory) as tmp:
        (tmp / "index.html").write_text(html, encoding="utf-8")
        for t in tests:
            write_table(tmp / f"{t.plan_path.parent.name}.csv", t.data)
        for th in thermal or ():
            write_table(tmp / f"{th.plan_path.parent.name}.csv", th.data)
            write_table(tmp / f"{th.plan_path.parent.name}_held_out.csv", th.held_out)
        for n in noise or []:
            from inertest.io.kalibr import write_kalibr_yaml

            write_kalibr_yaml(tmp / n.yaml_name, n.result, source=n.data_path.name)
        for a in acceptance or []:
            from inertest.report.acceptance import write_acceptance_report
            from inertest.report.lot import lot_page

            (tmp / "acceptance").mkdir(exist_ok=True)
            write_acceptance_report(
                tmp / "acceptance", a.outcome.to_dict(),
                {t.test.name: t.outcome.result for t in a.outcome.tests if t.outcome},
                command=command)
            if a.lot is not None:
                (tmp / "lot.html").write_text(lot_page(
                    a.lot, title=f"Lot report: {a.outcome.campaign.unit_type} (simulated)",
                    identity=[["serial", f"lot of {len(a.lot.serials)} simulated units"],
                              ["site", "simulated"], ["operator", "simulated"]]),
                    encoding="utf-8")
    return Path(directory) / "index.html"


@dataclass(frozen=True)
class DemoNoise:
    """Whole-IMU noise analysis of one recording listed under ``[[noise]]`` (not simulated)."""

    title: str
    data_path: Path
    result: Any  # inertest.noise.imu.ImuNoiseResult
    notes: tuple[str, ...] = ()

    @property
    def yaml_name(self) -> str:
        """File name of its Kalibr yaml in the report folder (``lasergyro_imu.yaml``)."""
        return f"{self.data_path.name.split('.')[0]}_imu.yaml"


def run_noise(campaign: str | os.PathLike[str], *,
              progress: Started | None = None) -> list[DemoNoise]:
    """Analyse every IMU recording listed under ``[[noise]]`` of the campaign (there may be none).

    Each entry: ``title``, ``data`` (a recording relative to the campaign file, any format
    :func:`inertest.io.imu_recording.read_imu_recording` reads, e.g. PSINS text ``.imu.xz``).
    """
    from inertest.io.imu_recording import read_imu_recording
    from inertest.noise.imu import analyse_imu_noise

    cpath = Path(campaign)
    entries = read_toml(cpath, "campaign").get("noise", [])
    if not isinstance(entries, list) or not all(
            isinstance(e, dict) and isinstance(e.get("data"), str) for e in entries):
        raise PlanError(f"campaign {cpath}: each [[noise]] entry needs data = \"FILE\" (an IMU "
                        "recording, relative to the campaign file)")
    out = []
    for k, e in enumerate(entries, start=1):
        _started(progress, k, len(entries), str(e.get("title", e["data"])))
        path = cpath.parent / e["data"]
        rec = read_imu_recording(path)
        if rec.t is None and rec.rate_hz is None:
            raise PlanError(f"campaign {cpath}: {path.name} has no time stamps and no sample "
                            "rate; list a recording that has them")
        result = analyse_imu_noise(rec.t, rec.gyro, rec.accel, gyro_names=rec.gyro_names,
                                   accel_names=rec.accel_names, rate_hz=rec.rate_hz)
        out.append(DemoNoise(str(e.get("title", path.name)), path, result, rec.notes))
    return out


def noise_sections(entries: list[DemoNoise]) -> list[Section]:
    """Report sections of the ``[[noise]]`` recordings: what was read, then the analysis."""
    from inertest.report.imu_noise import imu_noise_sections

    out = []
    for n in entries:
        out.append(Section(n.title, [paragraph(
            f"A real recording, not simulated: {n.data_path.name} ({n.result.duration_s:.0f} s "
            f"at {n.result.rate_hz:g} Hz, {len(n.result.channels)} channels). Overlapping Allan "
            "deviation and one-sided PSD per channel, the IEEE Std 952-1997 terms and the Kalibr "
            f"parameters; the Kalibr imu.yaml is {n.yaml_name} beside this report (the same as "
            f"`inertest noise {n.data_path.name} --kalibr imu.yaml`)."),
            *[paragraph(m, note=True) for m in n.notes]]))
        out += [Section(f"{n.title}: {s.title}", s.parts) for s in imu_noise_sections(n.result)]
    return out


#: Unit-to-unit spread of a simulated lot of the FOG acceptance example (1 sigma), per test and
#: coefficient: (absolute, relative). The bias is one offset per unit, seen by every test.
LOT_SPREAD = {
    "turn-on": {"B": (0.12, 0.0), "turn_on_sigma": (0.0, 0.25), "bias_instability": (0.0, 0.2)},
    "warm-up": {"B_final": (0.12, 0.0), "warm_up_amplitude": (0.0, 0.2),
                "time_constant": (0.0, 0.15)},
    "in-run": {"B": (0.12, 0.0), "bias_instability": (0.0, 0.2), "ARW": (0.0, 0.15)},
    "scale-factor": {"K": (0.0, 1e-4), "asymmetry": (10.0, 0.0), "K2": (0.03, 0.0)},
    "thermal": {"temperature_sensitivity": (0.0015, 0.0)},
}
#: The unit of a simulated lot planted with a high bias (+0.9 deg/h), to stand out.
LOT_OUTLIER = 6


def lot_truths(base: dict[str, dict[str, float]], units: int,
               rng: np.random.Generator | int | None = 100) -> list[dict[str, dict[str, float]]]:
    """Each unit's truth per test: the shipped unit's, moved by :data:`LOT_SPREAD`."""
    gen = np.random.default_rng(rng)
    out = []
    for u in range(units):
        offset = float(gen.normal())      # one bias offset per unit, shared by its tests
        truths = {}
        for name, t in base.items():
            t = dict(t)
            for k, (a, r) in LOT_SPREAD.get(name, {}).items():
                if k not in t:
                    continue
                if k in ("B", "B_final"):
                    t[k] = t[k] + a * offset + (0.9 if u == LOT_OUTLIER else 0.0)
                else:
                    t[k] = t[k] * (1.0 + r * gen.normal()) + a * gen.normal()
            truths[name] = t
        out.append(truths)
    return out


@dataclass(frozen=True)
class DemoAcceptance:
    """The acceptance campaign of the demo and, with ``lot``, a simulated lot of its type."""

    title: str
    manifest: Path
    outcome: Any                 # inertest.app.acceptance.AcceptanceOutcome
    lot: Any = None              # inertest.quality.lot.LotStatistics


def run_acceptance(campaign: str | os.PathLike[str]) -> list[DemoAcceptance]:
    """Run every ``[[acceptance]]`` campaign of the demo file (not stored), and its lot."""
    from inertest.app.acceptance import read_campaign, run_campaign
    from inertest.io.plan_file import load_truth
    from inertest.quality.lot import lot_statistics

    cpath = Path(campaign)
    out = []
    for e in read_toml(cpath, "campaign").get("acceptance", []):
        manifest = cpath.parent / e["campaign"]
        c = read_campaign(manifest)
        outcome = run_campaign(c, store=False)
        lot = None
        units = int(e.get("lot", 0))
        if units >= 2:
            base = {t.name: load_truth(t.truth) for t in c.tests if t.truth is not None}
            docs = []
            for u, truths in enumerate(lot_truths(base, units)):
                serial = f"{c.serial.rsplit('-', 1)[0]}-{9001 + u}"
                for k, t in enumerate(c.tests):
                    if t.name not in truths:
                        continue
                    plan = load_plan(t.plan)
                    plan = replace(plan, instrument=replace(plan.instrument, serial=serial))
                    data = simulate(plan, truths[t.name], noise=t.noise,
                                    rng=10_000 * (u + 1) + k)
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        docs.append(fit(plan, data, sigma=t.sigma).to_dict())
            verified: dict[str, list[str]] = {}
            for done in outcome.tests:
                if done.outcome is not None:
                    for cid in done.test.verifies:
                        verified.setdefault(cid, []).append(done.outcome.result.kind)
            lot = lot_statistics(docs, c.spec, clause_procedures=verified)
        out.append(DemoAcceptance(str(e.get("title", c.title)), manifest, outcome, lot))
    return out


def acceptance_sections(entries: list[DemoAcceptance]) -> list[Section]:
    """The demo report's summary of each campaign (its certificate and lot report beside it)."""
    from inertest.report.acceptance import CLAUSE_HEADER, clause_rows
    from inertest.report.html import table_html

    out = []
    for e in entries:
        doc = e.outcome.to_dict()
        sec = Section(e.title, [paragraph(
            f"An acceptance campaign ({e.manifest}): every test of one unit, each clause of its "
            "specification judged with the test's expanded uncertainty, one certificate for the "
            "series: acceptance/index.html and acceptance/certificate.json beside this report "
            f"(the same as `inertest campaign {e.manifest} --report DIR`). Overall verdict: "
            f"{e.outcome.overall}."),
            table_html(CLAUSE_HEADER, clause_rows(doc), left_columns=4,
                       caption="The certificate's clause table")])
        if e.lot is not None:
            sec.parts.append(paragraph(
                f"A simulated lot of {len(e.lot.serials)} units of the same type (coefficients "
                "drawn around this unit's, one with a high bias): lot statistics per quantity, "
                "process capability against the specification and the units that stand out, "
                "in lot.html beside this report (as `inertest lot --type ... --spec ...` gives "
                "from the history database)."))
        out.append(sec)
    return out
