"""Kalibr / OpenVINS ``imu.yaml``: write the measured noise model, read one back.

Keys and units (Kalibr wiki "IMU Noise Model"; OpenVINS ``kalibr_imu_chain.yaml`` holds the
same keys under ``imu0``):

==============================  ====================  ===========================================
key                             unit                  IEEE Std 952-1997 Annex C term
==============================  ====================  ===========================================
``gyroscope_noise_density``     rad/s/sqrt(Hz)        N, angle random walk [rad/sqrt(s)]
``gyroscope_random_walk``       rad/s^2/sqrt(Hz)      K, rate random walk [rad/s/sqrt(s)]
``accelerometer_noise_density`` m/s^2/sqrt(Hz)        N, velocity random walk [m/s/sqrt(s)]
``accelerometer_random_walk``   m/s^3/sqrt(Hz)        K, acceleration random walk [m/s^2/sqrt(s)]
``update_rate``                 Hz                    sample rate
==============================  ====================  ===========================================

The bias instability B (the flat floor of the Allan deviation, 0.664 B) is not the random walk.
Each value written is the largest over the sensor's axes; a term the record does not resolve is
written as an upper bound and says so in its comment (:mod:`inertest.noise.imu`).
"""

from __future__ import annotations

import math
import os
import re
import warnings
from pathlib import Path

import numpy as np

from inertest import __version__
from inertest.errors import DataError
from inertest.io.atomic import write_text
from inertest.noise.imu import ImuNoiseResult, KalibrTerm

#: The four noise keys, in the order written.
KEYS = ("gyroscope_noise_density", "gyroscope_random_walk", "accelerometer_noise_density",
        "accelerometer_random_walk")
_SENSORS = (("gyroscope", "gyro"), ("accelerometer", "accelerometer"))
_MEANING = {
    ("gyro", "noise_density"): "white rate noise density = angle random walk N",
    ("gyro", "random_walk"): "bias random walk = rate random walk K (NOT the bias instability B)",
    ("accelerometer", "noise_density"): "white noise density = velocity random walk N",
    ("accelerometer", "random_walk"): "bias random walk = acceleration random walk K (NOT the "
                                      "bias instability B)",
}


def _num(v: float) -> str:
    return format(float(v), ".10g")


def _rate(v: float) -> str:
    """A sample rate to 6 significant digits, written positionally (``100``, ``199.998``).

    The median interval of float time stamps carries their rounding (``100.0000954`` Hz from
    stamps written with 7 digits); 6 digits keep a crystal's real offset (1 ppm at 1 MHz is
    already the 7th) and drop that noise. Positional so that YAML reads a number.
    """
    import numpy as np

    return np.format_float_positional(float(f"{float(v):.6g}"), trim="-")


def _comment(kind: str, param: str, term: KalibrTerm, result: ImuNoiseResult) -> list[str]:
    axes = result.sensor(kind)
    per_axis = ", ".join(
        f"{c.name} {getattr(c, 'density' if param == 'noise_density' else 'random_walk').value:.4g}"
        for c in axes)
    lines = [f"# {_MEANING[(kind, param)]} [{term.unit}]; largest of the axes ({per_axis})"]
    if term.status == "fitted":
        lines.append(f"#   fitted IEEE 952 term, standard uncertainty {term.std:.3g} "
                     f"{term.unit}; its line meets the Allan deviation curve at tau = "
                     f"{term.tau_s:g} s")
    else:
        slope = "-1/2" if param == "noise_density" else "+1/2"
        lines.append(f"#   UPPER BOUND, not a measurement: the record does not resolve this "
                     f"term; the {slope} slope line tangent at tau = {term.tau_s:.4g} s to the "
                     f"one-sided upper confidence limits of the measured Allan deviation, "
                     f"jointly 95 % over all measured taus (Bonferroni), the upper_bound of the "
                     f"IEEE 952 block")
    return lines


def kalibr_yaml_text(result: ImuNoiseResult, *, source: str, rostopic: str = "/imu0") -> str:
    """The Kalibr ``imu.yaml`` of a noise analysis, with units and meanings in comments."""
    out = [
        f"# Kalibr / OpenVINS IMU noise model written by inertest {__version__} from {source}",
        "# Continuous-time parameters (Kalibr wiki 'IMU Noise Model'): the discrete-time white",
        "# noise of samples at dt is noise_density / sqrt(dt), the bias step per sample",
        "# random_walk * sqrt(dt). Values from the overlapping Allan deviation (IEEE Std 952-1997",
        f"# Annex C) of {result.duration_s:.6g} s of data at {result.rate_hz:.6g} Hz"
        + (", straight line removed" if result.detrended else "") + ".",
        "# The bias instability B (the flat floor of the Allan deviation) is NOT the random walk.",
        f"rostopic: {rostopic}",
        f"update_rate: {_rate(result.rate_hz)}  # [Hz] sample rate of the recording (6 digits)",
    ]
    for key_sensor, kind in _SENSORS:
        terms = result.kalibr(kind)
        if terms is None:
            out.append(f"# no {key_sensor} channels in the recording: no {key_sensor} keys")
            continue
        for param in ("noise_density", "random_walk"):
            term = terms[param]
            out.extend(_comment(kind, param, term, result))
            tag = "fitted" if term.status == "fitted" else "upper bound"
            out.append(f"{key_sensor}_{param}: {_num(term.value)}  # [{term.unit}] {tag}")
    return "\n".join(out) + "\n"


def write_kalibr_yaml(path: str | os.PathLike[str], result: ImuNoiseResult, *,
                      source: str, rostopic: str = "/imu0") -> Path:
    """Write :func:`kalibr_yaml_text` to ``path`` atomically."""
    return write_text(path, kalibr_yaml_text(result, source=source, rostopic=rostopic))


#: Kalibr's unit of each key (values are read in it, after conversion of a stated unit).
KALIBR_UNITS = {
    "gyroscope_noise_density": "rad/s/sqrt(Hz)",
    "gyroscope_random_walk": "rad/s^2/sqrt(Hz)",
    "accelerometer_noise_density": "m/s^2/sqrt(Hz)",
    "accelerometer_random_walk": "m/s^3/sqrt(Hz)",
    "update_rate": "Hz",
}


def _noise_unit(unit: str) -> tuple[float, tuple[float, ...]]:
    """Factor to SI and dimension of a unit with at most square roots: ``deg/sqrt(h)``.

    ``sqrt(U)`` after ``/`` divides, elsewhere multiplies; the rest is a compound unit of
    :func:`inertest.units.compound_unit`.
    """
    from inertest.units import compound_unit

    u = unit.replace(" ", "").replace("√", "sqrt")
    factor, dim = 1.0, np.zeros(len(compound_unit("1")[1]))
    for m in re.finditer(r"(/?)sqrt\(([^()]*)\)", u):
        f, d = compound_unit(m.group(2))
        sign = -0.5 if m.group(1) else 0.5
        factor *= f**sign
        dim += sign * np.asarray(d, dtype=float)
    rest = re.sub(r"/?\*?sqrt\([^()]*\)", "", u).strip("*") or "1"
    f, d = compound_unit(rest)
    return factor * f, tuple(dim + np.asarray(d, dtype=float))


def _unit_comments(text: str) -> dict[str, str]:
    """``key: value  # [unit] ...``: the bracketed unit of each key's own line."""
    out = {}
    for ln in text.splitlines():
        m = re.match(r"\s*([A-Za-z_]+)\s*:[^#]*#\s*\[([^\]]*)\]", ln)
        if m and m.group(1) in KALIBR_UNITS:
            out[m.group(1)] = m.group(2).strip()
    return out


#: Largest yaml file read [bytes]; a Kalibr imu.yaml is under 1 KiB.
MAX_YAML_BYTES = 1 << 20
#: Most values (scalars, lists, mappings) a yaml document may hold once its aliases are
#: expanded: ``&a [x, x, ...]`` referenced nine times nine levels deep (a "billion laughs")
#: is a small file that expands past any memory.
MAX_YAML_NODES = 100_000


def _check_yaml_size(root: object, path: Path) -> None:
    """Refuse a composed yaml document that expands (through its aliases) past the cap.

    The composed graph shares an aliased node, so counting with a memo costs the size of the
    file, not of its expansion; an alias to an enclosing node (a cycle) counts as too large.
    """
    import yaml

    sizes: dict[int, int] = {}
    active: set[int] = set()

    def size(node: object) -> int:
        key = id(node)
        if key in sizes:
            return sizes[key]
        if key in active:
            return MAX_YAML_NODES + 1
        active.add(key)
        n = 1
        if isinstance(node, yaml.SequenceNode):
            for child in node.value:
                n += size(child)
                if n > MAX_YAML_NODES:
                    break
        elif isinstance(node, yaml.MappingNode):
            for k, v in node.value:
                n += size(k) + size(v)
                if n > MAX_YAML_NODES:
                    break
        active.discard(key)
        sizes[key] = n
        return n

    if root is not None and size(root) > MAX_YAML_NODES:
        raise DataError(f"{path} is larger than {MAX_YAML_NODES} values once its aliases (*name) "
                        "are expanded; a Kalibr imu.yaml holds a few numbers: give the IMU's "
                        "yaml without aliases")


def read_kalibr_yaml(path: str | os.PathLike[str], *, notes: list[str] | None = None
                     ) -> dict[str, float | None]:
    """The noise parameters of a Kalibr or OpenVINS IMU yaml (missing keys -> None).

    Accepts the keys at the top level (Kalibr ``imu.yaml``) or under one ``imuN`` mapping
    (OpenVINS ``kalibr_imu_chain.yaml``; its OpenCV ``%YAML:1.0`` line is skipped). Also
    returns ``update_rate`` [Hz] when present. Values are in Kalibr's units
    (:data:`KALIBR_UNITS`): a unit comment on the key's line, ``key: value  # [unit]`` (as
    inertest writes it), is read and converted (``deg/sqrt(h)``, ``ug/sqrt(Hz)``, ...); a unit
    comment of another dimension, or one that cannot be read, is refused. Keys without a unit
    comment are taken in Kalibr's unit, with a note.

    Parameters
    ----------
    notes : list of str, optional
        Receives the notes (conversions, assumed units); without it they are warnings.
    """
    import yaml

    from inertest.errors import UnitError

    p = Path(path)
    if p.stat().st_size > MAX_YAML_BYTES:
        raise DataError(f"{p} is larger than {MAX_YAML_BYTES // 1024} KiB; a Kalibr imu.yaml "
                        "holds a few lines: give the IMU's yaml, not another file")
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise DataError(f"{p} is not UTF-8 text; give the IMU's Kalibr yaml") from None
    stated = _unit_comments(text)
    lines = text.splitlines()
    if lines and lines[0].startswith("%YAML:"):
        text = "\n".join(lines[1:])
    try:
        _check_yaml_size(yaml.compose(text, Loader=yaml.SafeLoader), p)
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise DataError(f"{p} is not valid YAML ({str(exc).splitlines()[0]}); fix the file") \
            from None
    if not isinstance(doc, dict):
        raise DataError(f"{p} holds no YAML mapping; expected Kalibr keys such as "
                        "gyroscope_noise_density")
    if not any(k in doc for k in KEYS):
        nested = [v for k, v in doc.items() if isinstance(v, dict) and any(q in v for q in KEYS)]
        if len(nested) != 1:
            raise DataError(f"{p} has none of the Kalibr keys {', '.join(KEYS)} (at the top "
                            "level or under one imu0 mapping); fix the file")
        doc = nested[0]
    out: dict[str, float | None] = {}
    for k in (*KEYS, "update_rate"):
        v = doc.get(k)
        if v is None:
            out[k] = None
            continue
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) or v < 0:
            raise DataError(f"{p}: {k} is {v!r}; expected a non-negative number in the Kalibr "
                            "unit")
        out[k] = float(v)
    if all(out[k] is None for k in KEYS):
        raise DataError(f"{p} has no value for any of {', '.join(KEYS)}; fix the file")
    said: list[str] = []
    assumed = []
    for k, v in out.items():
        if v is None:
            continue
        want = KALIBR_UNITS[k]
        unit = stated.get(k)
        if unit is None:
            if k != "update_rate":
                assumed.append(k)
            continue
        try:
            f, dim = _noise_unit(unit)
        except UnitError:
            raise DataError(f"{p}: {k} states the unit [{unit}], which inertest cannot read; "
                            f"write it in Kalibr's unit {want} (or e.g. deg/sqrt(h), "
                            "ug/sqrt(Hz))") from None
        f0, dim0 = _noise_unit(want)
        if not np.allclose(dim, dim0):
            raise DataError(f"{p}: {k} states the unit [{unit}], which is not a unit of "
                            f"Kalibr's {want}; fix the value or its unit comment")
        if not math.isclose(f, f0, rel_tol=1e-12):
            out[k] = v * f / f0
            said.append(f"{p.name}: {k} = {v:g} {unit} read as {out[k]:.6g} {want}")
    if assumed:
        said.append(f"{p.name}: no unit comment for {', '.join(assumed)}; Kalibr's units "
                    f"assumed ({', '.join(KALIBR_UNITS[k] for k in assumed)})")
    if notes is not None:
        notes.extend(said)
    else:
        for msg in said:
            warnings.warn(msg, UserWarning, stacklevel=2)
    return out
