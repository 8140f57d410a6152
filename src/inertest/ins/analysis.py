"""An INS error analysis as one result: the responses, the periods, the random errors' sigma.

``inertest ins-errors`` and the Python API return :class:`InsErrorAnalysis`, whose
:meth:`~InsErrorAnalysis.to_dict` is the ``ins-errors`` result envelope (schema 2): the combined
error histories of every state, the characteristic periods, and with random sources the
standard deviation of each state over time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from inertest.ins.covariance import RandomSources, propagate_covariance
from inertest.ins.error_model import (
    SIGN_CONVENTION,
    STATE_UNITS,
    STATES,
    LinearValidity,
    linear_validity,
)
from inertest.ins.propagation import (
    CharacteristicPeriods,
    SourceResponses,
    characteristic_periods,
    source_responses,
)
from inertest.ins.scenario import InsScenario
from inertest.results import envelope


@dataclass(frozen=True)
class InsErrorAnalysis:
    """Error propagation of a local-level INS on a static base (source 002).

    Attributes
    ----------
    scenario : InsScenario
        Site, errors and time span.
    responses : SourceResponses
        Each source's and the combined error histories (computed - true, SI).
    periods : CharacteristicPeriods
        Schuler, Foucault and Earth periods of the error equations [s].
    sigma : ndarray, shape (n, 9), or None
        Standard deviation of each state under the random sources (None without them).
    """

    scenario: InsScenario
    responses: SourceResponses
    periods: CharacteristicPeriods
    sigma: NDArray[np.float64] | None = None

    kind = "ins-errors"

    @property
    def linear_model(self) -> LinearValidity:
        """How far the linear error model holds over the span (its largest attitude error)."""
        phi = [STATES.index(s) for s in ("phiE", "phiN", "phiU")]
        return linear_validity(self.responses.combined[:, phi])

    def to_dict(self) -> dict[str, object]:
        """The ``ins-errors`` result envelope: histories, periods, units, sign convention."""
        resp = self.responses
        out: dict[str, Any] = {"t": resp.t.tolist()}
        for i, st in enumerate(STATES):
            out[st] = resp.combined[:, i].tolist()
        out["periods"] = {k: (v if not isinstance(v, float) or math.isfinite(v) else None)
                          for k, v in self.periods.as_dict().items()}
        out["units"] = {"t": "s", **STATE_UNITS, "periods": "s"}
        out["sign_convention"] = SIGN_CONVENTION
        if self.sigma is not None:
            out["sigma"] = {st: self.sigma[:, i].tolist() for i, st in enumerate(STATES)}
        out["linear_model"] = self.linear_model.to_dict()
        site = self.scenario.site
        note = self.linear_model.message
        return envelope("ins-errors", result=out, messages=[note] if note else [], site={
            "latitude_deg": math.degrees(site.latitude_rad), "gravity_m_s2": site.gravity_m_s2,
            "radius_m": site.radius_m, "earth_rate_rad_s": site.earth_rate_rad_s})


def analyse(scenario: InsScenario, randoms: RandomSources | None = None) -> InsErrorAnalysis:
    """Responses to every error source of ``scenario``, and the random errors' sigma.

    Parameters
    ----------
    scenario : InsScenario
    randoms : RandomSources, optional
        Angle and velocity random walk, rate random walk; the covariance is propagated when
        any is non-zero.
    """
    resp = source_responses(scenario)
    sigma = None
    if randoms is not None and randoms.densities().any():
        sigma = propagate_covariance(scenario.site, resp.t, randoms).sigma
    return InsErrorAnalysis(scenario, resp, characteristic_periods(scenario.site), sigma)
