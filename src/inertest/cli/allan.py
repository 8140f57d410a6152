"""``inertest allan``: Allan-family deviations and IEEE 952 noise terms of one data column."""

from __future__ import annotations

import dataclasses
import math
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import click
import numpy as np

from inertest.cli import safe_line
from inertest.cli._common import (
    DATA_PATH,
    REAL,
    check_paths,
    echo_json,
    figure_format,
    input_identity,
    print_table,
    recording_options,
    save_figure,
)
from inertest.errors import DataError, InputError
from inertest.io.atomic import write_text
from inertest.io.raw_samples import RAW_DTYPES, SampleFile, read_samples
from inertest.noise.confidence import NOISE_RULES
from inertest.noise.deviations import STATISTICS, DeviationResult, deviations, min_samples
from inertest.results import envelope
from inertest.units import ACCEL_UNITS, ARCSEC_TO_RAD, DEG_TO_RAD, RATE_UNITS

if TYPE_CHECKING:
    from inertest.noise.identification import NoiseModel

# Column unit -> (factor to SI, SI rate unit of the deviation, instrument kind).
_UNITS: dict[str, tuple[float, str, str | None]] = {
    **{u: (f, "rad/s", "gyro") for u, f in RATE_UNITS.items()},
    **{u: (f, "m/s^2", "accelerometer") for u, f in ACCEL_UNITS.items()},
    "1": (1.0, "1", None),
}
_ANGLE_UNITS: dict[str, tuple[float, str, str | None]] = {
    "rad": (1.0, "rad/s", "gyro"),
    "deg": (DEG_TO_RAD, "rad/s", "gyro"),
    "arcsec": (ARCSEC_TO_RAD, "rad/s", "gyro"),
    "m/s": (1.0, "m/s^2", "accelerometer"),
    "1": (1.0, "1", None),
}


def _scaled(r: DeviationResult, f: float) -> DeviationResult:
    return dataclasses.replace(r, dev=r.dev * f, dev_lo=r.dev_lo * f, dev_hi=r.dev_hi * f)


def _dev_unit(unit: str, data_type: str) -> str:
    """Unit the deviations are shown in: the user's rate unit (angle input: angle unit / s)."""
    if data_type == "rate" or unit == "1":
        return unit
    return "m/s^2" if unit == "m/s" else f"{unit}/s"


def _stat_unit(stat: str, rate_unit: str) -> str:
    """Unit of a statistic: the rate unit, except TDEV (rate unit x s: an angle, a velocity)."""
    if stat != "tdev":
        return rate_unit
    return {"rad/s": "rad", "deg/s": "deg", "deg/h": "arcsec", "arcsec/s": "arcsec",
            "m/s^2": "m/s", "1": "s"}.get(rate_unit, f"{rate_unit}*s")


def _tau_option(text: str) -> str | list[float]:
    if text in ("octave", "decade", "all"):
        return text
    try:
        return [float(t) for t in text.split(",") if t.strip()]
    except ValueError:
        raise click.BadParameter(
            f"expected octave, decade, all or comma-separated seconds, got {text!r}",
            param_hint="--taus",
        ) from None


def _column_unit(unit: str | None, data_type: str) -> tuple[str, float, str | None]:
    """The column's unit (default rad/s, angle input rad), its factor to SI, the instrument."""
    table = _ANGLE_UNITS if data_type == "angle" else _UNITS
    unit = unit or ("rad" if data_type == "angle" else "rad/s")
    if unit not in table:
        raise InputError(f"unknown --unit {unit!r} for {data_type} input; use one of "
                         f"{', '.join(table)}")
    factor, _, instrument = table[unit]
    return unit, factor, instrument


def _check_rate(rate_hz: float) -> None:
    if not (math.isfinite(rate_hz) and rate_hz > 0):
        raise InputError(f"--rate must be a positive sampling rate in Hz, got {rate_hz:g}")
    if not 1e-9 <= rate_hz <= 1e12:
        raise InputError(f"--rate {rate_hz:g} Hz is not a usable sample rate; give the rate in "
                         "Hz, between 1e-9 and 1e12")


def _statistics(stats: str) -> list[str]:
    """The statistics of ``--stats``, each one of :data:`STATISTICS`."""
    names = [s.strip() for s in stats.split(",") if s.strip()]
    bad = [s for s in names if s not in STATISTICS]
    if bad or not names:
        raise InputError(f"unknown statistic {bad[0] if bad else stats!r} in --stats; choose "
                         f"from {', '.join(STATISTICS)}")
    return names


def _long_enough(names: list[str], n: int, data_type: str) -> tuple[list[str], list[str]]:
    """The statistics a record of ``n`` samples allows, and a warning for each left out."""
    short = [f"the record ({n} samples) is too short for {s}: it needs at least "
             f"{min_samples(s, data_type)} {data_type} samples; left out"
             for s in names if n < min_samples(s, data_type)]
    names = [s for s in names if n >= min_samples(s, data_type)]
    if not names:
        raise DataError(short[0].removesuffix("; left out"))
    return names, short


def _deviations(samples: np.ndarray | SampleFile, rate_hz: float, want: list[str], taus: str,
                data_type: str) -> dict[str, DeviationResult]:
    """The deviations, with a progress bar on a terminal."""
    from inertest.cli._common import progress_bar

    with progress_bar("allan") as tick:
        return deviations(samples, rate_hz, want, _tau_option(taus), data_type,
                          progress=lambda d, t: tick("deviations", d, t))


def _noise_terms(res: dict[str, DeviationResult], samples: np.ndarray | SampleFile,
                 factor: float, instrument: str | None, data: Path, unit: str
                 ) -> tuple[NoiseModel, list[str]]:
    """The IEEE 952 noise terms fitted to the overlapping Allan variance [SI], and the checks."""
    from inertest.noise.identification import identify_noise

    if not np.any(res["oadev"].var > 0):
        raise DataError(f"{data.name} is constant (every sample is {float(samples[0]):g} "
                        f"{unit}): there is no noise to analyse; check the recording and "
                        "--column")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = identify_noise(res["oadev"], instrument=instrument,
                               data=samples * factor if isinstance(samples, np.ndarray)
                               and not isinstance(samples, np.memmap) else None)
    checks = list(model.checks)
    checks += [str(w.message) for w in caught if str(w.message) not in checks]
    return model, checks


def _json_result(shown: dict[str, DeviationResult], model: NoiseModel | None,
                 checks: list[str], short: list[str], *, dev_unit: str, rate_hz: float,
                 data_type: str, samples: int) -> None:
    """Print the result envelope: every statistic on one tau grid, the noise terms."""
    grid = sorted({float(t) for r in shown.values() for t in r.taus})
    out: dict[str, object] = {"tau": grid, "unit": dev_unit, "rate_hz": rate_hz,
                              "input": data_type, "samples": samples}
    for k, r in shown.items():
        pos = {float(t): i for i, t in enumerate(r.taus)}

        def col(a: np.ndarray, pos: dict[float, int] = pos) -> list[float | int | None]:
            return [a[pos[t]].item() if t in pos else None for t in grid]

        out[k] = col(r.dev)
        out[f"{k}_lo"] = col(r.dev_lo)
        out[f"{k}_hi"] = col(r.dev_hi)
        out[f"{k}_n"] = col(r.n)
        out[f"{k}_edf"] = col(r.edf)
        out[f"{k}_alpha"] = col(r.alpha)
        rule = dict(zip(r.taus.tolist(), r.alpha_rule, strict=True))
        out[f"{k}_alpha_rule"] = [rule.get(t) for t in grid]
    out["units"] = {k: _stat_unit(k, dev_unit) for k in shown}
    out["alpha_rules"] = NOISE_RULES
    out["confidence"] = next(iter(shown.values())).confidence
    out["noise_terms"] = model.to_dict() if model is not None else None
    verdict = "ok" if model is None or not checks else "warning"
    echo_json(envelope(
        "allan", result=out, messages=short + checks,
        checks=[] if model is None else [{"name": "five-term noise model", "verdict": verdict,
                                          "findings": checks}]))


def _print_tables(title: str, shown: dict[str, DeviationResult], model: NoiseModel | None,
                  *, dev_unit: str, samples: int, rate_hz: float) -> None:
    """The deviation table and the noise terms, for a terminal."""
    from inertest.report.noise import deviation_rows, noise_rows

    header, rows = deviation_rows(shown)
    units = {k: _stat_unit(k, dev_unit) for k in shown}
    print_table(f"{title}: deviations [{', '.join(f'{k} {u}' for k, u in units.items())}] "
                f"({math.floor(samples):d} samples at {rate_hz:g} Hz)", header, rows)
    if model is not None:
        header, rows = noise_rows(model)
        print_table("noise terms (IEEE Std 952-1997, fitted to the overlapping Allan variance)",
                    header, rows)
        click.echo(f"fit: {model.verdict}")


@click.command()
@click.argument("data", type=DATA_PATH)
@recording_options
@click.option("--column", default=None,
              help="Column to analyse (tables; index for a 2-D .npy). Optional if only one.")
@click.option("--rate", "rate_hz", type=REAL, required=True, help="Sample rate [Hz].")
@click.option("--input", "data_type", type=click.Choice(["rate", "angle"]), default="rate",
              show_default=True, help="Rate samples, or integrated angle/velocity samples.")
@click.option("--unit", default=None,
              help="Unit of the column: rate rad/s, deg/s, deg/h, m/s^2, g, mg, ug; angle rad, "
                   "deg, arcsec, m/s; or 1 (dimensionless). Default rad/s (angle: rad).")
@click.option("--taus", default="octave", show_default=True,
              help="octave, decade, all, or taus in seconds T1,T2,...")
@click.option("--stats", default="oadev", show_default=True,
              help=f"Comma-separated statistics: {', '.join(STATISTICS)}.")
@click.option("--dtype", type=click.Choice(RAW_DTYPES), default=None,
              help="Sample type of a raw binary file (.bin/.raw).")
@click.option("--no-noise-id", is_flag=True, help="Skip the IEEE 952 noise-term fit.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.option("--plot", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the figure (.png, .svg or .pdf).")
@click.option("--report", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write a self-contained HTML report (figure, noise terms, deviation table).")
def allan(data: Path, topic: str | None, layout: Path | None, column: str | None,
          rate_hz: float, data_type: str, unit: str | None,
          taus: str, stats: str, dtype: str | None, no_noise_id: bool, as_json: bool,
          plot: Path | None, report: Path | None) -> None:
    """Allan, modified Allan, time, Hadamard and total deviations of DATA (NIST SP 1065).

    Fits the IEEE Std 952-1997 noise terms (quantization, random walk, bias instability, rate
    random walk, rate ramp) to the overlapping Allan variance unless --no-noise-id.
    """
    # Here rather than at import: `inertest allan --help` should not load scipy.stats/matplotlib.
    from inertest.report.html import Section, page, table_html
    from inertest.report.noise import allan_figure, allan_sections

    unit, factor, instrument = _column_unit(unit, data_type)
    figure_format(plot)
    check_paths([plot, report], [data])
    _check_rate(rate_hz)
    names = _statistics(stats)
    samples = read_samples(data, column, dtype=dtype, topic=topic, layout=layout)
    names, short = _long_enough(names, len(samples), data_type)
    for text in short:
        click.echo(safe_line(f"warning: {text}"), err=True)
    want = list(dict.fromkeys(names + ([] if no_noise_id or "oadev" in names else ["oadev"])))
    res = _deviations(samples, rate_hz, want, taus, data_type)
    res = {k: _scaled(v, factor) for k, v in res.items()}  # SI for the noise fit
    model = None
    checks: list[str] = []
    if not no_noise_id:
        model, checks = _noise_terms(res, samples, factor, instrument, data, unit)
        for text in checks:
            click.echo(f"warning: {text}", err=True)
    dev_unit = _dev_unit(unit, data_type)
    shown = {k: _scaled(res[k], 1.0 / factor) for k in names}  # in the user's unit
    if plot is not None:
        fig = allan_figure(shown, model, unit=dev_unit, title=f"{data.name}",
                           scale=1.0 / factor)
        save_figure(fig, plot)
    if report is not None:
        settings = [["data", data.name], ["column", column or "(the only one)"],
                    ["samples", str(len(samples))], ["sample rate", f"{rate_hz:g} Hz"],
                    ["input", data_type], ["unit of the column", unit],
                    ["deviations in", dev_unit]]
        write_text(report, page(
            f"Noise analysis of {data.name}",
            [Section("Record", [table_html(["setting", "value"], settings)]),
             *allan_sections(shown, model, unit=dev_unit, scale=1.0 / factor)],
            subtitle="Allan-family deviations (NIST SP 1065) and IEEE Std 952-1997 noise terms",
            identity=input_identity([data])))
    if as_json:
        _json_result(shown, model, checks, short, dev_unit=dev_unit, rate_hz=rate_hz,
                     data_type=data_type, samples=int(len(samples)))
        return
    _print_tables(data.name, shown, model, dev_unit=dev_unit, samples=len(samples),
                  rate_hz=rate_hz)
    if plot is not None:
        click.echo(safe_line(f"figure: {plot}"))
    if report is not None:
        click.echo(safe_line(f"report: {report}"))
