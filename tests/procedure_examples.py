"""The example of every procedure kind, shared by the tests that run them all."""

from __future__ import annotations

#: Procedure kind -> (plan folder under examples/, truth file relative to it, noise per reading).
EXAMPLES = {
    "polar-tumble": ("polar_tumble", "truth.toml", 0.002),
    "local-level-tumble": ("local_level_tumble", "../polar_tumble/truth.toml", 0.002),
    "gyro-rate-table": ("gyro_rate_table", "truth.toml", 0.01),
    "gyro-triad-rotation": ("gyro_triad_rotation", "truth.toml", 1.0),
    "ferraris": ("ferraris", "truth.toml", 0.0),  # its truth file gives the noise
    "triad-multiposition": ("triad_multiposition", "truth.toml", 1e-4),
    "accelerometer-multipoint": ("accelerometer_multipoint", "truth.toml", 1e-6),
    "centrifuge-nine-position": ("centrifuge", "truth.toml", 1e-9),
    "servo-table": ("servo_table", "truth.toml", 0.5),  # arcsec per encoder reading
    "orientation-free": ("orientation_free", "truth.toml", 0.0),  # its truth file gives the noise
    "systematic": ("systematic", "truth.toml", 0.0),  # its truth file gives the noise
    "turn-on-repeatability": ("turn_on_repeatability", "truth.toml", 0.0),  # truth gives noise
    "in-run-stability": ("in_run_stability", "truth.toml", 0.0),  # truth gives noise
    "warm-up": ("warm_up", "truth.toml", 0.0),  # truth gives noise
    "scale-factor-repeatability": ("scale_factor_repeatability", "truth.toml", 2.0),
    "temperature-sensitivity": ("temperature_sensitivity", "truth.toml", 0.01),
}
