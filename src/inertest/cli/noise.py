"""``inertest noise``: every gyro and accelerometer channel of an IMU recording; Kalibr yaml."""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import click

from inertest.cli import safe_line
from inertest.cli._common import (
    DATA_PATH,
    REAL,
    check_paths,
    echo_json,
    input_identity,
    print_table,
    progress_bar,
    recording_options,
)
from inertest.errors import DataError, InputError
from inertest.io.imu_recording import FORMATS, TIME_UNITS
from inertest.results import envelope
from inertest.units import ACCEL_UNITS, RATE_UNITS

if TYPE_CHECKING:
    from inertest.io.imu_recording import ImuRecording
    from inertest.io.recordings.imu import SpilledImu
    from inertest.noise.imu import ImuNoiseResult

_GAPS = ("refuse", "longest")
_OUTLIERS = ("keep", "refuse", "clip")


@click.command()
@click.argument("data", type=DATA_PATH)
@click.option("--format", "fmt", type=click.Choice(FORMATS), default="auto", show_default=True,
              help="File format (auto: by suffix; PSINS text by content).")
@recording_options
@click.option("--time-column", default=None,
              help="Time-stamp column, or 'secs,nsecs' (ROS). Default a common name if any.")
@click.option("--time-unit", type=click.Choice(TIME_UNITS), default="auto", show_default=True,
              help="Unit of the time column (auto: ns when the median interval exceeds 100, "
                   "else s).")
@click.option("--gyro-columns", default=None, help="Gyro columns x,y,z (1 to 3).")
@click.option("--accel-columns", default=None, help="Accelerometer columns x,y,z (1 to 3).")
@click.option("--gyro-unit", type=click.Choice(list(RATE_UNITS)), default="rad/s",
              show_default=True, help="Unit of the gyro columns.")
@click.option("--accel-unit", type=click.Choice(list(ACCEL_UNITS)), default="m/s^2",
              show_default=True, help="Unit of the accelerometer columns (g = 9.80665 m/s^2).")
@click.option("--rate", "rate_hz", type=REAL, default=None,
              help="Sample rate [Hz]: needed without time stamps, else checked against them.")
@click.option("--gaps", type=click.Choice(_GAPS), default="refuse", show_default=True,
              help="Gaps or duplicated stamps: refuse, or analyse the longest clean segment.")
@click.option("--outliers", type=click.Choice(_OUTLIERS), default="keep", show_default=True,
              help="Samples beyond --outlier-threshold robust sigmas: keep (counted), refuse, "
                   "or clip.")
@click.option("--outlier-threshold", type=REAL, default=10.0, show_default=True,
              help="Outlier threshold [robust sigmas from a running median].")
@click.option("--detrend", is_flag=True, help="Remove a straight line from each channel.")
@click.option("--kalibr", "kalibr_out", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="Write a Kalibr / OpenVINS imu.yaml.")
@click.option("--unresolved", type=click.Choice(["bound", "refuse"]), default="bound",
              show_default=True,
              help="A Kalibr term the record does not resolve: write its upper bound (marked) "
                   "or refuse to write the yaml.")
@click.option("--compare", "compare_yaml", type=click.Path(exists=True, dir_okay=False,
                                                           path_type=Path),
              default=None, help="A Kalibr yaml (datasheet, another tool) to compare with.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.option("--report", "report_dir", type=click.Path(file_okay=False, path_type=Path),
              default=None, help="Write an HTML report folder (index.html).")
def noise(data: Path, fmt: str, topic: str | None, layout: Path | None,
          time_column: str | None, time_unit: str,
          gyro_columns: str | None, accel_columns: str | None, gyro_unit: str, accel_unit: str,
          rate_hz: float | None, gaps: str, outliers: str, outlier_threshold: float,
          detrend: bool, kalibr_out: Path | None, unresolved: str, compare_yaml: Path | None,
          as_json: bool, report_dir: Path | None) -> None:
    """Noise of every gyro and accelerometer channel of an IMU recording in DATA.

    Time-stamp checks (gaps, jitter, duplicates), outliers, overlapping Allan deviation and PSD
    per channel, the IEEE Std 952-1997 terms with uncertainties, and the Kalibr continuous-time
    noise density and random walk (--kalibr writes imu.yaml; --compare reads one back).
    """
    from inertest.io.atomic import check_outputs, check_report_directory
    from inertest.io.kalibr import KEYS, read_kalibr_yaml, write_kalibr_yaml
    from inertest.io.recordings.imu import SpilledImu, open_imu
    from inertest.noise.imu import compare_kalibr

    check_paths([kalibr_out], [data, compare_yaml])
    if report_dir is not None:  # before any work: nothing is written half-way
        check_report_directory(report_dir)
        check_outputs([report_dir], [data, compare_yaml] if compare_yaml else [data])
    if report_dir is not None and kalibr_out is not None and (
            kalibr_out.resolve().parent == report_dir.resolve()):
        raise InputError(f"--kalibr {kalibr_out} is inside the report folder {report_dir}; "
                         "write it elsewhere")
    yaml_notes: list[str] = []
    claimed = (read_kalibr_yaml(compare_yaml, notes=yaml_notes) if compare_yaml is not None
               else None)
    for m in yaml_notes:
        click.echo(safe_line(f"warning: {m}"), err=True)
    with contextlib.ExitStack() as spilled:
        with progress_bar("noise") as tick:  # long recordings: decoded once, then streamed
            rec = open_imu(data, fmt=fmt, topic=topic, layout=layout, time_column=time_column,
                           time_unit=time_unit, gyro_columns=gyro_columns,
                           accel_columns=accel_columns, gyro_unit=gyro_unit,
                           accel_unit=accel_unit,
                           progress=lambda done, total: tick("reading", done, total))
        if isinstance(rec, SpilledImu):
            spilled.enter_context(rec)  # its temporary files go, whatever happens next
        result = _analyse(data, rec, rate_hz, gaps, outliers, outlier_threshold, detrend)
    comparisons = compare_kalibr(result, {k: claimed[k] for k in KEYS}) if claimed else ()
    if kalibr_out is not None and unresolved == "refuse":
        loose = [f"{c.name} {t.term}" for c in result.channels
                 for t in (c.density, c.random_walk) if t.status != "fitted"]
        if loose:
            raise DataError(f"the record does not resolve {', '.join(loose)}; nothing written. "
                            "Record longer or more quietly, or give --unresolved bound to write "
                            "upper bounds")
    messages = [*rec.notes, *result.messages]
    html = None
    if report_dir is not None:
        from inertest.report.html import page
        from inertest.report.imu_noise import imu_noise_sections

        html = page(f"IMU noise of {data.name}", imu_noise_sections(result, comparisons),
                    subtitle="Overlapping Allan deviation (NIST SP 1065), PSD, IEEE Std "
                             "952-1997 Annex C terms, Kalibr parameters",
                    identity=input_identity([data, compare_yaml]))

    def kalibr() -> None:
        assert kalibr_out is not None
        write_kalibr_yaml(kalibr_out, result, source=data.name,
                          rostopic=topic if topic and topic.startswith("/") else "/imu0")

    _write_both(report_dir, html, [p for p in (data, compare_yaml) if p], kalibr_out, kalibr)
    if as_json:
        out = result.to_dict()
        out["kalibr"] = {kind: ({k: v.to_dict() for k, v in terms.items()} if terms else None)
                         for kind in ("gyro", "accelerometer")
                         for terms in [result.kalibr(kind)]}
        out["comparison"] = [c.to_dict() for c in comparisons]
        checks = [{"name": f"{c.name}: five-term noise model",
                   "verdict": "ok" if c.model.fits else "warning",
                   "findings": list(c.model.checks)} for c in result.channels]
        echo_json(envelope("imu-noise", result=out, checks=checks, messages=messages))
        return
    from inertest.report.imu_noise import comparison_rows, summary_rows, timing_rows

    for m in result.messages:
        click.echo(safe_line(f"warning: {m}"), err=True)
    h, r = timing_rows(result)
    print_table(f"{data.name}: record", h, r)
    h, r = summary_rows(result)
    print_table("noise per channel: Kalibr noise density N and random walk K (< : upper bound "
                "from the tangent line), IEEE 952 bias instability B", h, r)
    if comparisons:
        h, r = comparison_rows(comparisons)
        print_table(f"claimed values of {compare_yaml.name if compare_yaml else ''}", h, r)
    if kalibr_out is not None:
        click.echo(safe_line(f"kalibr: {kalibr_out}"))
    if report_dir is not None:
        click.echo(safe_line(f"report: {report_dir / 'index.html'}"))


def _analyse(data: Path, rec: ImuRecording | SpilledImu, rate_hz: float | None, gaps: str,
             outliers: str, outlier_threshold: float, detrend: bool) -> ImuNoiseResult:
    """The noise analysis of a recording in memory, or streamed from its temporary files."""
    from inertest.io.recordings.imu import SpilledImu
    from inertest.noise.imu import analyse_imu_noise
    from inertest.noise.imu_stream import analyse_imu_noise_stream

    rate = rate_hz if rate_hz is not None else rec.rate_hz
    if rec.t is None and rate is None:
        raise InputError(f"{data.name} has no time stamps: give the sample rate with --rate, or "
                         "the time column with --time-column")
    if isinstance(rec, SpilledImu):
        with progress_bar("noise") as tick:
            return analyse_imu_noise_stream(
                rec.t, rec.channels, gyro_names=rec.gyro_names, accel_names=rec.accel_names,
                rate_hz=rate, gaps=gaps, outliers=outliers,
                outlier_threshold=outlier_threshold, detrend=detrend, progress=tick,
                time_unit=getattr(rec, "time_unit", None))
    for name, col, si in [*zip(rec.gyro_names, rec.gyro.T, ["rad/s"] * 3, strict=False),
                          *zip(rec.accel_names, rec.accel.T, ["m/s^2"] * 3, strict=False)]:
        if col.size and (col == col[0]).all():  # no noise: nothing to fit (all deviations 0)
            raise DataError(f"channel {name} of {data.name} is constant ({col[0]:g} {si} in "
                            "every sample): there is no noise to analyse; check the recording, "
                            "or leave the channel out with --gyro-columns / --accel-columns")
    return analyse_imu_noise(rec.t, rec.gyro, rec.accel, gyro_names=rec.gyro_names,
                             accel_names=rec.accel_names, rate_hz=rate, gaps=gaps,
                             outliers=outliers, outlier_threshold=outlier_threshold,
                             detrend=detrend, time_unit=rec.time_unit)


def _write_both(report_dir: Path | None, html: str | None, inputs: list[Path],
                kalibr_out: Path | None, kalibr: Callable[[], None]) -> None:
    """The report folder and the Kalibr yaml: both or neither.

    The yaml is written before the report folder moves into place and withdrawn if that
    fails (a failed yaml left the report behind).
    """
    from inertest.io.atomic import target_directory

    if report_dir is None:
        if kalibr_out is not None:
            kalibr()
        return
    wrote = False
    try:
        with target_directory(report_dir, inputs=inputs) as tmp:
            (tmp / "index.html").write_text(html or "", encoding="utf-8")
            if kalibr_out is not None:
                kalibr()
                wrote = True
    except BaseException:
        if wrote and kalibr_out is not None:
            kalibr_out.unlink(missing_ok=True)
        raise
