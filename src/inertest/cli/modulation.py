"""``inertest modulation``: rotation modulation studies (component and system level)."""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np

from inertest.analysis import stator_modulation as sm
from inertest.cli._common import echo_json, parse_float_list, print_table
from inertest.io.atomic import target_file
from inertest.report.modulation import component_figure
from inertest.units import DEG_PER_H_TO_RAD_PER_S, DEG_PER_S_TO_RAD_PER_S, HOUR_TO_S


@click.group()
def modulation() -> None:
    """Rotation modulation of drift: a gyro's rotating stator, or a rotating IMU in an INS."""


@modulation.command()
@click.option("--stator-hz", default="1,2,5,10", show_default=True,
              help="Stator rotation frequencies to compare [Hz], comma-separated.")
@click.option("--sample-hz", type=float, default=1000.0, show_default=True,
              help="Sample rate [Hz]; a multiple of every stator frequency.")
@click.option("--duration-s", type=float, default=60.0, show_default=True)
@click.option("--periods", type=int, default=1, show_default=True,
              help="Stator periods per integral-filter window.")
@click.option("--drift-deg-h", default="5,-3", show_default=True,
              help="Constant drift X,Y fixed to the stator [deg/h].")
@click.option("--drift-ramp-deg-h-per-h", default="0,0", show_default=True,
              help="Temperature-like drift trend X,Y [deg/h per h].")
@click.option("--drift-random-walk", type=float, default=0.0, show_default=True,
              help="Drift random walk [deg/h/sqrt(h)].")
@click.option("--drift-sine-deg-h", type=float, default=0.0, show_default=True,
              help="Amplitude of a stator-fixed periodic drift [deg/h].")
@click.option("--drift-sine-hz", type=float, default=0.0, show_default=True,
              help="Its frequency [Hz] (near the stator frequency it is not cancelled).")
@click.option("--noise-deg-h", type=float, default=0.0, show_default=True,
              help="White measurement noise per sample [deg/h].")
@click.option("--house-rate-deg-s", default="0.01,0", show_default=True,
              help="Constant house rate X,Y [deg/s].")
@click.option("--house-sine-deg-s", type=float, default=0.0,
              help="Amplitude of a sinusoidal house rate about X [deg/s].")
@click.option("--house-sine-hz", type=float, default=0.1)
@click.option("--seed", type=int, default=0)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object (SI and deg/h).")
@click.option("--plot", type=click.Path(dir_okay=False, path_type=Path), default=None)
def component(stator_hz: str, sample_hz: float, duration_s: float, periods: int,
              drift_deg_h: str, drift_ramp_deg_h_per_h: str, drift_random_walk: float,
              drift_sine_deg_h: float, drift_sine_hz: float, noise_deg_h: float,
              house_rate_deg_s: str, house_sine_deg_s: float, house_sine_hz: float, seed: int,
              as_json: bool, plot: Path | None) -> None:
    """Stator rotation of a suspended gyro (seed 001): residual drift with and without it."""
    k = DEG_PER_H_TO_RAD_PER_S
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
    runs = [sm.run_modulation(t, house, drift, stator_rate_rad_s=2 * np.pi * f,
                              sample_rate_hz=sample_hz, periods=periods, noise=noise)
            for f in rates_hz]
    if plot is not None:
        fig = component_figure(runs)
        with target_file(plot) as tmp:
            fig.savefig(tmp, format=plot.suffix.lstrip(".") or "png", dpi=110,
                        bbox_inches="tight")
    rows = [{"stator_hz": f, "rms_residual_modulated_deg_h": r.rms(True) / k,
             "rms_residual_fixed_deg_h": r.rms(False) / k, "delay_s": r.cost.delay_s,
             "bandwidth_hz": r.cost.bandwidth_hz, "window_s": r.cost.window_s}
            for f, r in zip(rates_hz, runs, strict=True)]
    if as_json:
        echo_json({"runs": rows, "units": {"rms": "deg/h", "delay": "s", "bandwidth": "Hz"}})
        return
    print_table("stator rotation modulation: residual drift after whole-period integration",
                ["stator [Hz]", "RMS residual [deg/h]", "no modulation [deg/h]", "delay [s]",
                 "bandwidth [Hz]"],
                [[f"{r['stator_hz']:g}", f"{r['rms_residual_modulated_deg_h']:.3g}",
                  f"{r['rms_residual_fixed_deg_h']:.3g}", f"{r['delay_s']:.3g}",
                  f"{r['bandwidth_hz']:.3g}"] for r in rows])
    if plot is not None:
        click.echo(f"figure: {plot}")
