"""``inertest plan-check``: whether a test plan can verify a specification, before testing."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

from inertest.cli import safe_line
from inertest.cli._common import REAL, FiniteFloatRange, echo_json, print_table
from inertest.report.rounding import format_number, round_to_uncertainty

if TYPE_CHECKING:
    from collections.abc import Mapping

    from inertest.quality.lab import Equipment
    from inertest.quality.plan_check import PlanCheck

_FILE = click.Path(exists=True, dir_okay=False, path_type=Path)

#: Exit status when a limit cannot be verified by the plan (not an input error: that is 2).
EXIT_NOT_VERIFIABLE = 1


@click.command()
@click.argument("plan", type=_FILE)
@click.option("--spec", "spec_path", type=_FILE, default=None,
              help="Instrument specification (TOML, see examples/specs); required except for "
              "a systematic calibration, whose every state's std is printed, and a campaign, "
              "which names its own.")
@click.option("--noise", "noise_path", type=_FILE, default=None,
              help="Noise per reading in the output unit (TOML/JSON: sigma, position_offset, "
              "random_walk, flicker, unit) or the JSON of `inertest allan --json`; for a "
              "systematic calibration the IMU's noise (gyro_arw_deg_rt_h, acc_vrw_ug_rt_hz, "
              "...; examples/systematic/imu_noise.toml).")
@click.option("--compare", "compare", type=_FILE, multiple=True,
              help="Systematic calibration: another sequence's plan to predict beside PLAN "
              "(repeatable), e.g. a 9- against a 19-position scheme.")
@click.option("--equipment", type=_FILE, default=None,
              help="Lab equipment file: the Type B of the plan's [test] equipment enters U.")
@click.option("--truth", type=_FILE, default=None,
              help="Nominal coefficients to simulate with (default zero, with the plan's "
              "nominal scale factor; when the procedure needs a scale factor the plan does not "
              "give, the truth.toml beside the plan).")
@click.option("--sample-interval", "sample_interval_s", type=REAL, default=None,
              help="Seconds between readings, to map Allan terms (default: the plan's rate).")
@click.option("--tur", type=FiniteFloatRange(min=1.0), default=3.0, show_default=True,
              help="Test uncertainty ratio: a limit is verifiable when U <= tolerance / TUR.")
@click.option("--mc", "n_mc", type=click.IntRange(min=20), default=200, show_default=True,
              help="Most simulated tests of the Monte Carlo (noise other than white or equal "
              "position offsets); it stops earlier once every std is known to --mc-error.")
@click.option("--mc-error", "rel_error", type=FiniteFloatRange(min=0.0), default=0.1,
              show_default=True,
              help="Relative standard error of the Monte Carlo std at which it stops (0: run "
              "all --mc tests).")
@click.option("--seed", type=int, default=0, show_default=True, help="Monte Carlo seed.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def plan_check(plan: Path, spec_path: Path | None, noise_path: Path | None,
               compare: tuple[Path, ...], equipment: Path | None, truth: Path | None,
               sample_interval_s: float | None, tur: float, n_mc: int, rel_error: float,
               seed: int, as_json: bool) -> None:
    """Predict each limited quantity's U from PLAN and a noise model, before testing.

    A limit is verifiable when the predicted U (k = 2: Type A from the plan and the noise,
    Type B of the equipment and site gravity) is at most tolerance / TUR (3:1 by default).
    When a limit is not, the cheapest change (longer dwell, more positions or repeats, more
    mountings) that makes it verifiable is printed with its predicted U.

    PLAN may also be an acceptance campaign (a manifest with a [campaign] table, see inertest
    campaign): every test is then simulated on its nominal unit (its truth.toml, which carries
    the unit's own noise) and each clause of the campaign's specification is predicted
    verifiable or not, before anything is measured; --spec and --noise are not needed.

    Exit status: 0 when every limit is verifiable, 1 when one is not (marginal, not
    verifiable or not determined by the plan), 2 for bad input.
    """
    from inertest.io.plan_file import read_toml

    if "campaign" in read_toml(plan, "plan"):
        _check_campaign(plan, tur=tur, n_mc=n_mc, rel_error=rel_error, seed=seed,
                        as_json=as_json)
        return
    if noise_path is None:
        raise click.UsageError("plan-check of a plan needs --noise NOISE.toml (a campaign "
                               "names its own)")
    from inertest.api import load_plan
    from inertest.io.plan_file import load_truth
    from inertest.quality.conformance import read_spec
    from inertest.quality.lab import read_equipment, select_equipment, unchecked_equipment_message
    from inertest.quality.plan_check import NominalTruthError, check_plan, read_noise

    p = load_plan(plan)
    if p.kind == "systematic":
        limits = read_spec(spec_path) if spec_path is not None else None
        if not _systematic([plan, *compare], noise_path, equipment, truth, as_json, limits,
                           tur):
            raise SystemExit(EXIT_NOT_VERIFIABLE)
        return
    if compare:
        raise click.UsageError("--compare is for the sequences of a systematic calibration")
    if spec_path is None:
        raise click.UsageError(f"plan-check of a {p.kind} plan needs --spec (the limits)")
    spec = read_spec(spec_path)
    noise = read_noise(noise_path, p, sample_interval_s=sample_interval_s)
    used: tuple[Equipment, ...] = ()
    if equipment is not None and p.test is not None:
        used = select_equipment(read_equipment(equipment), p.test.equipment,
                                plan_source=f"plan {plan}", lab_source=f"lab file {equipment}")
    tr = load_truth(truth) if truth is not None else None

    def check(truth_values: Mapping[str, float] | None, nominal: str | None) -> PlanCheck:
        return check_plan(p, spec, noise, truth=truth_values, nominal=nominal, equipment=used,
                          tur=tur, n_mc=n_mc, rng=seed, rel_error=rel_error)

    try:
        out = check(tr, None if truth is None else f"the truth file {truth}")
    except NominalTruthError:
        beside = plan.parent / "truth.toml"
        if truth is not None or not beside.is_file():
            raise
        out = check(load_truth(beside),
                    f"the truth file {beside} beside the plan (the procedure needs a scale "
                    "factor; --truth FILE to give another)")
    if equipment is None and p.test is not None and p.test.equipment:
        click.echo(f"warning: {safe_line(unchecked_equipment_message(p.test.equipment))}",
                   err=True)
    if as_json:
        echo_json(out.to_dict())
    else:
        _print(out)
    if not out.ok:
        raise SystemExit(EXIT_NOT_VERIFIABLE)


def _systematic(plans: list[Path], noise_path: Path, equipment: Path | None,
                truth: Path | None, as_json: bool, limits, tur: float) -> bool:  # noqa: ANN001
    """The predicted std of every state of each sequence, side by side.

    With ``limits`` (a Spec) the verdict of each sequence on each limit; True when every limit
    is verifiable.
    """
    from inertest.api import load_plan
    from inertest.io.plan_file import load_truth
    from inertest.models.strapdown_imu import StateSet
    from inertest.quality.lab import read_equipment, select_equipment
    from inertest.quality.plan_check import (
        IMU_NOISE_KEYS,
        judge_sequence,
        predict_sequence,
        read_imu_noise,
    )

    noise = read_imu_noise(noise_path)
    tr = load_truth(truth) if truth is not None else None
    preds = []
    for path in plans:
        p = load_plan(path)
        if p.kind != "systematic":
            raise click.UsageError(f"{path} is a {p.kind} plan; --compare takes systematic "
                                   "plans")
        used: tuple[Equipment, ...] = ()
        if equipment is not None and p.test is not None:
            used = select_equipment(read_equipment(equipment), p.test.equipment,
                                    plan_source=f"plan {path}", lab_source=f"lab file {equipment}")
        preds.append(predict_sequence(p, noise, label=str(path), truth=tr, equipment=used))
    all_states = StateSet(lever_arms="xyz", g_sensitivity=True, asymmetric_scale=True).names()
    verdicts = ([judge_sequence(x, limits, names=all_states, tur=tur) for x in preds]
                if limits is not None else [])
    ok = all(c.status == "verifiable" for v in verdicts for c in v)
    if as_json:
        seqs = [x.to_dict() for x in preds]
        for d, v in zip(seqs, verdicts, strict=False):
            d["limits"] = [c.to_dict() for c in v]
            d["all_verifiable"] = all(c.status == "verifiable" for c in v)
        echo_json({"kind": "plan-check", "procedure": "systematic", "noise": noise.to_dict(),
                   "test_uncertainty_ratio": tur, "sequences": seqs})
        return ok
    click.echo(safe_line("noise: " + ", ".join(f"{k} = {v:g} {IMU_NOISE_KEYS[k]}"
                                               for k, v in noise.levels.items())))
    click.echo("prediction: generalised least squares of the navigation-mode velocity errors "
               "with this noise (no data needed); Type B: site gravity (the table's angle, "
               "rate and tilt do not enter: the gyros measure the turns)")
    names: list[str] = []
    for x in preds:
        names += [n for n in x.std_a if n not in names]
    header = ["state", "unit"] + [f"{x.label} ({x.turns} turns, {x.duration_s:.0f} s)"
                                  for x in preds]
    rows = []
    for n in names:
        unit = next(x.std_a[n][1] for x in preds if n in x.std_a)
        cells = []
        for x in preds:
            if n not in x.std_a:
                cells.append("not determined")
                continue
            s_a = x.std_a[n][0]
            u_c = (s_a**2 + x.type_b.get(n, 0.0) ** 2) ** 0.5
            cells.append(format_number(u_c, digits=2))
        rows.append([n, unit, *cells])
    print_table("predicted standard uncertainty (Type A and B combined, k = 1)", header, rows)
    for x in preds:
        for s in x.not_determined:
            click.echo(safe_line(f"{x.label}: not determined: {s}"))
    for x, v in zip(preds, verdicts, strict=False):
        print_table(f"{x.label} against the limits (U: k = 2, verifiable when U <= tolerance / "
                    f"{tur:g})", ["quantity", "limit", "U (k = 2)", "U / tolerance", "status"],
                    [[c.quantity, c.limit, _u(c.expanded, c.unit),
                      "-" if c.expanded is None else f"{c.expanded / c.tolerance:.3g}",
                      c.status] for c in v])
    return ok


#: A Type B below this fraction of its row's combined std is round-off of the noise-free
#: simulations (a zero nominal instrument gives 1e-16); it cannot change U in a printed digit.
_TYPE_B_ROUND_OFF = 1e-9


def _u(x: float | None, unit: str) -> str:
    """A standard or expanded uncertainty to two significant digits (GUM 7.2.6)."""
    return "-" if x is None else f"{round_to_uncertainty(x, x)[1]} {unit}"


def _type_b(c) -> str:  # noqa: ANN001 - LimitCheck
    """The Type-B std of a row, round-off relative to the row's combined std printed as 0."""
    if c.type_b is None:
        return "-"
    uc = (c.std_a**2 + c.type_b**2) ** 0.5 if c.std_a is not None else c.type_b
    if c.type_b < _TYPE_B_ROUND_OFF * uc or c.type_b == 0:
        return f"0 {c.unit}"
    return f"{format_number(c.type_b, digits=2)} {c.unit}"


def _print(out) -> None:  # noqa: ANN001 - PlanCheck
    n = out.noise
    click.echo(safe_line(
        f"noise per reading: white {n.sigma:.3g}, position offset {n.position_offset:.3g}, "
        f"random-walk step {n.random_walk:.3g}, flicker {n.flicker:.3g} {n.unit}"))
    for note in n.notes:
        click.echo(safe_line(f"  {note}"))
    click.echo(safe_line(f"nominal instrument: {out.nominal}"))
    click.echo(safe_line(f"prediction: {out.plan.method}"))
    header = ["quantity", "limit", "predicted std (Type A)", "Type B", "U (k = 2)",
              "U / tolerance", "status"]
    rows = [[c.quantity, c.limit, _u(c.std_a, c.unit), _type_b(c),
             _u(c.expanded, c.unit),
             "-" if c.expanded is None else f"{c.expanded / c.tolerance:.3g}", c.status]
            for c in out.plan.limits]
    print_table(f"plan as written ({out.plan.readings} readings)", header, rows)
    for c in out.plan.limits:
        if c.status == "not determined":
            click.echo(safe_line(f"not determined: {c.note}"))
    click.echo(safe_line(f"rule: {out.rule}"))
    if out.ok:
        click.echo("the plan can verify every limit")
        return
    s = out.suggestion
    if all(c.status in ("verifiable", "not determined") for c in out.plan.limits):
        click.echo("the quantities not determined need another procedure or more mountings "
                   "(see above); no dwell or repeat makes them identifiable")
        return
    if s is None:
        tried = ", ".join(c.label for c in out.candidates) or "none applies to this procedure"
        click.echo(safe_line(f"no single change tried makes every limit verifiable (tried: "
                             f"{tried})"))
        return
    click.echo(safe_line(f"cheapest change: {s.label} ({s.readings} readings instead of "
                         f"{out.plan.readings})"))
    print_table(f"with {s.label}", header[:1] + ["U (k = 2)", "U / tolerance", "status"],
                [[c.quantity, _u(c.expanded, c.unit),
                  "-" if c.expanded is None else f"{c.expanded / c.tolerance:.3g}", c.status]
                 for c in s.limits])


def _check_campaign(manifest: Path, *, tur: float, n_mc: int, rel_error: float, seed: int,
                    as_json: bool) -> None:
    """``plan-check CAMPAIGN``: which clauses the planned series can verify."""
    from inertest.app.acceptance import read_campaign
    from inertest.io.plan_file import load_truth
    from inertest.quality.lab import read_equipment, select_equipment
    from inertest.quality.plan_check import SeriesTest, check_series

    c = read_campaign(manifest)
    lab = read_equipment(c.equipment) if c.equipment is not None else None
    tests = []
    for t in c.tests:
        from inertest.api import load_plan

        p = load_plan(t.plan)
        used = (select_equipment(lab, p.test.equipment, plan_source=f"plan {t.plan}",
                                 lab_source=f"lab file {c.equipment}")
                if lab is not None and p.test is not None else ())
        tests.append(SeriesTest(t.name, p, None if t.truth is None else load_truth(t.truth),
                                t.noise, t.verifies, used))
    out = check_series(tests, c.spec, tur=tur, n_mc=min(n_mc, 100), rng=seed,
                       rel_error=max(rel_error, 0.15))
    if as_json:
        echo_json(out.to_dict())
    else:
        rows = [[r.clause_id, r.test or "-", "-" if r.check is None else r.check.limit,
                 "-" if r.check is None else _u(r.check.expanded, r.check.unit),
                 "-" if r.check is None or r.check.expanded is None
                 else f"{r.check.expanded / r.check.tolerance:.3g}", r.status]
                for r in out.clauses]
        print_table(f"campaign {manifest}: can the planned series verify {c.spec.name}?",
                    ["clause", "test", "limit", "predicted U (k = 2)", "U / tolerance",
                     "status"], rows)
        for name, pred in out.predictions:
            click.echo(safe_line(f"{name}: {pred.method}"))
        click.echo(safe_line(f"rule: {out.rule}"))
        click.echo("the planned series can verify every clause" if out.ok
                   else "not every clause is verifiable as planned (see status)")
    if not out.ok:
        raise SystemExit(EXIT_NOT_VERIFIABLE)
