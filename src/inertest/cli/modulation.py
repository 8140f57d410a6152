"""``inertest modulation``: rotation modulation studies (component and system level)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click
import numpy as np

from inertest.cli._common import (
    REAL,
    check_paths,
    echo_json,
    figure_format,
    input_identity,
    parse_float_list,
    print_table,
    save_figure,
)
from inertest.units import (
    DEG_PER_H_TO_RAD_PER_S,
    DEG_PER_S_TO_RAD_PER_S,
    HOUR_TO_S,
    MICRO_G_TO_M_PER_S2,
    PPM_TO_RATIO,
)

if TYPE_CHECKING:
    from inertest.studies.rotation_modulation import ImuErrors

#: The rotation schemes of :data:`inertest.studies.rotation_modulation.SCHEMES`, spelt out so
#: that the studies, scipy and matplotlib load only when a command runs (a test checks them).
_SCHEMES = ("none", "single-axis", "four-position", "sixteen-position")


@click.group()
def modulation() -> None:
    """Rotation modulation of drift: a gyro's rotating stator, or a rotating IMU in an INS."""


@modulation.command()
@click.option("--stator-hz", default="1,2,5,10", show_default=True,
              help="Stator rotation frequencies to compare [Hz], comma-separated.")
@click.option("--sample-hz", type=REAL, default=1000.0, show_default=True,
              help="Sample rate [Hz]; a multiple of every stator frequency.")
@click.option("--duration-s", type=REAL, default=60.0, show_default=True)
@click.option("--periods", type=int, default=1, show_default=True,
              help="Stator periods per integral-filter window.")
@click.option("--drift-deg-h", default="5,-3", show_default=True,
              help="Constant drift X,Y fixed to the stator [deg/h].")
@click.option("--drift-ramp-deg-h-per-h", default="0,0", show_default=True,
              help="Temperature-like drift trend X,Y [deg/h per h].")
@click.option("--drift-random-walk", type=REAL, default=0.0, show_default=True,
              help="Drift random walk [deg/h/sqrt(h)].")
@click.option("--drift-sine-deg-h", type=REAL, default=0.0, show_default=True,
              help="Amplitude of a stator-fixed periodic drift [deg/h].")
@click.option("--drift-sine-hz", type=REAL, default=0.0, show_default=True,
              help="Its frequency [Hz] (near the stator frequency it is not cancelled).")
@click.option("--noise-deg-h", type=REAL, default=0.0, show_default=True,
              help="White measurement noise per sample [deg/h].")
@click.option("--house-rate-deg-s", default="0.01,0", show_default=True,
              help="Constant house rate X,Y [deg/s].")
@click.option("--house-sine-deg-s", type=REAL, default=0.0,
              help="Amplitude of a sinusoidal house rate about X [deg/s].")
@click.option("--house-sine-hz", type=REAL, default=0.1)
@click.option("--seed", type=int, default=0)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object (SI and deg/h).")
@click.option("--plot", type=click.Path(dir_okay=False, path_type=Path), default=None)
def component(stator_hz: str, sample_hz: float, duration_s: float, periods: int,
              drift_deg_h: str, drift_ramp_deg_h_per_h: str, drift_random_walk: float,
              drift_sine_deg_h: float, drift_sine_hz: float, noise_deg_h: float,
              house_rate_deg_s: str, house_sine_deg_s: float, house_sine_hz: float, seed: int,
              as_json: bool, plot: Path | None) -> None:
    """Stator rotation of a suspended gyro: residual drift with and without it.

    Source: patent, stator rotation modulation for suspended gyros.
    """
    from inertest.report.modulation import component_figure, component_rows
    from inertest.studies import stator_modulation as sm

    check_paths([plot], [])
    figure_format(plot)
    k = DEG_PER_H_TO_RAD_PER_S
    if not (np.isfinite(sample_hz) and sample_hz > 0):
        raise click.BadParameter(f"the sample rate must be positive, got {sample_hz:g} Hz",
                                 param_hint="--sample-hz")
    if not (np.isfinite(duration_s) and duration_s * sample_hz <= 1e8):
        raise click.BadParameter(f"{duration_s:g} s at {sample_hz:g} Hz is more than 1e8 "
                                 "samples; shorten --duration-s or lower --sample-hz",
                                 param_hint="--duration-s")
    rates_hz = parse_float_list(stator_hz, name="--stator-hz")
    if not rates_hz or any(r <= 0 for r in rates_hz):
        raise click.BadParameter("stator frequencies must be positive (0 = no modulation is "
                                 "always shown for comparison)", param_hint="--stator-hz")
    if duration_s <= 0 or periods < 1:
        raise click.BadParameter("duration must be positive and periods >= 1")
    t = np.arange(0.0, duration_s, 1.0 / sample_hz)
    rng = np.random.default_rng(seed)
    drift = sm.drift_scenario(
        t,
        constant=np.array(parse_float_list(drift_deg_h, name="--drift-deg-h", count=2)) * k,
        ramp=np.array(parse_float_list(drift_ramp_deg_h_per_h, name="--drift-ramp-deg-h-per-h",
                                       count=2)) * k / HOUR_TO_S,
        random_walk=drift_random_walk * k / np.sqrt(HOUR_TO_S),
        sine_amplitude=drift_sine_deg_h * k, sine_hz=drift_sine_hz, rng=rng)
    house = np.broadcast_to(
        np.array(parse_float_list(house_rate_deg_s, name="--house-rate-deg-s", count=2))
        * DEG_PER_S_TO_RAD_PER_S, (t.size, 2)).copy()
    house[:, 0] += house_sine_deg_s * DEG_PER_S_TO_RAD_PER_S * np.sin(2 * np.pi * house_sine_hz * t)
    noise = rng.normal(0.0, noise_deg_h * k, size=(t.size, 2)) if noise_deg_h else None
    study = sm.ComponentStudy(tuple(rates_hz), tuple(
        sm.run_modulation(t, house, drift, stator_rate_rad_s=2 * np.pi * f,
                          sample_rate_hz=sample_hz, periods=periods, noise=noise)
        for f in rates_hz))
    if plot is not None:
        fig = component_figure(list(study.runs))
        save_figure(fig, plot)
    if as_json:
        echo_json(study.to_dict())
        return
    header, rows, notes = component_rows(study)
    print_table("stator rotation modulation: residual drift after whole-period integration",
                header, rows)
    for n in notes:
        click.echo(f"note: {n}")
    if plot is not None:
        click.echo(f"figure: {plot}")


@modulation.command()
@click.option("--latitude", "latitude_deg", type=REAL, default=45.0, show_default=True,
              help="Site latitude [deg].")
@click.option("--hours", type=REAL, default=24.0, show_default=True, help="Simulated span [h].")
@click.option("--step", "step_s", type=REAL, default=60.0, show_default=True,
              help="Output step [s] (the propagation is exact; the step only samples it).")
@click.option("--scheme", type=click.Choice(_SCHEMES), default="single-axis",
              show_default=True, help="Rotation scheme (ignored with --compare).")
@click.option("--rate-deg-s", type=REAL, default=6.0, show_default=True,
              help="Rotation rate [deg/s]: continuous rotation, or the turns between positions.")
@click.option("--dwell-s", type=REAL, default=60.0, show_default=True,
              help="Dwell at each indexing position [s].")
@click.option("--alternate", is_flag=True,
              help="single-axis: reverse the direction after every --revolutions turns.")
@click.option("--revolutions", type=int, default=1, show_default=True)
@click.option("--heading-deg", type=REAL, default=0.0, show_default=True,
              help="Static IMU (scheme none): azimuth of body x from east, CCW [deg].")
@click.option("--gyro-drift-deg-h", default="0.01,0.01,0.01", show_default=True,
              help="Constant gyro drift on body X,Y,Z [deg/h] (output error: w_out = w_true "
                   "+ drift).")
@click.option("--gyro-drift-trend-deg-h-per-h", default="0,0,0", show_default=True,
              help="Linear drift trend on body X,Y,Z [deg/h per h].")
@click.option("--accel-bias-ug", default="50,50,50", show_default=True,
              help="Accelerometer bias on body X,Y,Z [ug]; Z does not enter (no vertical "
                   "channel).")
@click.option("--scale-factor-ppm", default="0,0,0", show_default=True,
              help="Gyro scale-factor errors X,Y,Z [ppm] (couple with mount and Earth rate).")
@click.option("--accel-scale-factor-ppm", default="0,0,0", show_default=True,
              help="Accelerometer scale-factor errors X,Y,Z [ppm].")
@click.option("--gyro-misalignment-urad", default="0,0,0,0,0,0", show_default=True,
              help="Gyro misalignment M_xy,M_xz,M_yx,M_yz,M_zx,M_zy [urad]: M_ij is gyro i's "
                   "sensitivity to the rate about body axis j (triad model convention).")
@click.option("--compare", is_flag=True,
              help="Run every scheme on the same IMU errors and tabulate the errors.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object (SI, with units).")
@click.option("--plot", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the figure (format from the suffix: .png, .svg, .pdf).")
@click.option("--report", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write a self-contained HTML report (figure and tables).")
def system(latitude_deg: float, hours: float, step_s: float, scheme: str, rate_deg_s: float,
           dwell_s: float, alternate: bool, revolutions: int, heading_deg: float,
           gyro_drift_deg_h: str, gyro_drift_trend_deg_h_per_h: str, accel_bias_ug: str,
           scale_factor_ppm: str, accel_scale_factor_ppm: str, gyro_misalignment_urad: str,
           compare: bool, as_json: bool, plot: Path | None, report: Path | None) -> None:
    """IMU on a rotating mount in a static-base INS: navigation errors with and without it."""
    from inertest.ins.error_model import SIGN_CONVENTION, InsSite
    from inertest.io.atomic import write_text
    from inertest.report.html import page
    from inertest.report.modulation import (
        SYSTEM_RESIDUAL_HEADER,
        SYSTEM_SUMMARY_HEADER,
        system_figure,
        system_residual_rows,
        system_sections,
        system_summary_rows,
    )
    from inertest.studies import rotation_modulation as rm

    figure_format(plot)
    check_paths([plot, report], [])
    if not (np.isfinite(hours) and hours > 0):
        raise click.BadParameter(f"the span must be positive, got {hours} h", param_hint="--hours")
    span = hours * HOUR_TO_S
    if not (np.isfinite(step_s) and 0 < step_s <= span):
        raise click.BadParameter(f"the step must be positive and at most the span ({span:g} s), "
                                 f"got {step_s} s", param_hint="--step")
    n = int(np.floor(span / step_s + 1e-9))
    t = np.append(np.arange(n + 1) * step_s, span) if n * step_s < span - 1e-9 else (
        np.arange(n + 1) * step_s)
    site = InsSite(np.radians(latitude_deg))
    imu = _imu_errors(gyro_drift_deg_h, gyro_drift_trend_deg_h_per_h, accel_bias_ug,
                      scale_factor_ppm, accel_scale_factor_ppm, gyro_misalignment_urad)
    rate = rate_deg_s * DEG_PER_S_TO_RAD_PER_S
    heading = np.radians(heading_deg)
    if compare:
        runs = rm.compare_schemes(site, imu, t, rate_rad_s=rate, dwell_s=dwell_s,
                                  heading_rad=heading)
    else:
        s = rm.make_scheme(scheme, span, rate_rad_s=rate, dwell_s=dwell_s, heading_rad=heading,
                           alternate=alternate, revolutions=revolutions)
        runs = [rm.run_scheme(site, s, imu, t)]
    study = rm.SystemStudy(latitude_deg, imu, tuple(runs), compare)
    for note in study.messages:
        click.echo(f"warning: {note}", err=True)
    if plot is not None:
        fig = system_figure(runs)
        save_figure(fig, plot)
    if report is not None:
        write_text(report, page("Rotation modulation of a strapdown INS", system_sections(runs),
                                subtitle=f"latitude {latitude_deg:g} deg, {hours:g} h",
                                identity=input_identity(
                                    source="simulated (noise-free): IMU errors and scheme from "
                                           "the command's options")))
    if as_json:
        echo_json(study.to_dict())
        return
    click.echo(f"sign convention: {SIGN_CONVENTION}")
    print_table(f"INS errors over {hours:g} h at latitude {latitude_deg:g} deg (max |error|; "
                "vertical channel not modelled)", SYSTEM_SUMMARY_HEADER,
                system_summary_rows(runs))
    print_table("what the scheme leaves: equivalent constant IMU errors (mean over one cycle, "
                "navigation frame; drift trend excluded)", SYSTEM_RESIDUAL_HEADER,
                system_residual_rows(runs))
    if plot is not None:
        click.echo(f"figure: {plot}")
    if report is not None:
        click.echo(f"report: {report}")


def _imu_errors(drift: str, trend: str, bias: str, sf: str, asf: str,
                mis: str) -> ImuErrors:
    from inertest.models import triad
    from inertest.studies import rotation_modulation as rm

    vec = lambda text, name: np.array(parse_float_list(text, name=name, count=3))  # noqa: E731
    off = parse_float_list(mis, name="--gyro-misalignment-urad", count=6)
    gyro = triad.TriadErrors.from_engineering(
        "gyroscope", scale_ppm=vec(sf, "--scale-factor-ppm"),
        misalignment_urad=dict(zip(triad.MISALIGNMENT_NAMES, off, strict=True)),
        bias=vec(drift, "--gyro-drift-deg-h"))
    accel = triad.TriadErrors(
        scale_deviation=vec(asf, "--accel-scale-factor-ppm") * PPM_TO_RATIO,
        bias=vec(bias, "--accel-bias-ug") * MICRO_G_TO_M_PER_S2)
    return rm.ImuErrors.from_triads(
        gyro, accel, gyro_drift_rate=vec(trend, "--gyro-drift-trend-deg-h-per-h")
        * DEG_PER_H_TO_RAD_PER_S / HOUR_TO_S)
