"""Allan-family deviations (NIST SP 1065) and IEEE Std 952 noise identification.

``oadev(data, rate, taus="octave", data_type="rate")`` and likewise ``adev``, ``mdev``,
``tdev``, ``hdev``, ``ohdev``, ``totdev`` return a :class:`DeviationResult` (``.taus`` [s],
``.dev``, ``.n`` terms, ``.edf``, ``.dev_lo``/``.dev_hi`` confidence bounds).
:func:`identify_noise` fits quantization, random walk, bias instability, rate random walk and
rate ramp to the Allan variance. Several statistics of one record at once:
:func:`inertest.noise.deviations.deviations`. Rate input: N samples -> N + 1 phase points with
a leading zero; the deviation has the unit of the rate.
"""

from inertest.noise.deviations import (
    STATISTICS,
    DeviationResult,
    adev,
    hdev,
    mdev,
    oadev,
    ohdev,
    tdev,
    totdev,
)
from inertest.noise.identification import NoiseModel, NoiseTerm, identify_noise, simulate_noise

__all__ = [
    "STATISTICS",
    "DeviationResult",
    "NoiseModel",
    "NoiseTerm",
    "adev",
    "hdev",
    "identify_noise",
    "mdev",
    "oadev",
    "ohdev",
    "simulate_noise",
    "tdev",
    "totdev",
]
