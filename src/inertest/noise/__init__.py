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

#: Names from the noise-identification module, imported on first use (it needs scipy.stats and
#: scipy.optimize, ~1 s: `inertest allan --help` and the deviations alone do not).
_LAZY = ("NoiseModel", "NoiseTerm", "identify_noise", "simulate_noise")


def __getattr__(name: str) -> object:
    if name in _LAZY:
        from inertest.noise import identification

        return getattr(identification, name)
    raise AttributeError(f"module 'inertest.noise' has no attribute {name!r}")

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
