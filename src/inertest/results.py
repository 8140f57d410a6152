"""Result types shared by the procedures: estimates and combinations with their units."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

#: Version of the JSON layout written by ``to_dict`` methods; bump on incompatible change.
SCHEMA_VERSION = 1


@dataclass(frozen=True)
class Estimate:
    """A coefficient determined by the data, in engineering units.

    Attributes
    ----------
    name : str
    value : float
        Estimate [unit].
    std : float
        Standard uncertainty (1 sigma) [unit].
    unit : str
    """

    name: str
    value: float
    std: float
    unit: str

    def to_dict(self) -> dict[str, float | str]:
        """``{"value", "std", "unit"}``."""
        return {"value": self.value, "std": self.std, "unit": self.unit}


@dataclass(frozen=True)
class Combination:
    """An identifiable linear combination of coefficients: ``value = sum(terms[k] * k)``.

    The weights carry the powers of g that make the sum come out in ``unit`` (the unit of the
    term whose weight is 1).
    """

    name: str
    terms: Mapping[str, float]
    value: float
    std: float
    unit: str

    def to_dict(self) -> dict[str, object]:
        """``{"name", "terms", "value", "std", "unit"}``."""
        return {
            "name": self.name,
            "terms": dict(self.terms),
            "value": self.value,
            "std": self.std,
            "unit": self.unit,
        }

    def evaluate(self, coefficients: Mapping[str, float]) -> float:
        """The combination applied to given coefficients (same units as the estimates)."""
        return float(sum(w * coefficients.get(k, 0.0) for k, w in self.terms.items()))


@dataclass(frozen=True)
class Identification:
    """What a linear test determined about an error model, in engineering units.

    Attributes
    ----------
    coefficients : dict
        Individually identifiable coefficients.
    combinations : tuple of Combination
        A basis of identifiable combinations of the other coefficients.
    not_separable : tuple of str
        Plain-language statements of what the test cannot determine, and why.
    covariance : ndarray
        Covariance of all coefficient estimates in engineering units (meaningful only along
        identifiable directions).
    names : tuple of str
        Coefficient names in model order.
    noise_sigma : float
        Noise per observation [noise_unit], estimated from the residuals unless given.
    noise_unit : str
    sigma_from_residuals : bool
    dof : int
        Residual degrees of freedom.
    rank : int
        Rank of the design (number of independent quantities determined).
    residuals : ndarray
        Observation minus model [noise_unit].
    """

    coefficients: dict[str, Estimate]
    combinations: tuple[Combination, ...]
    not_separable: tuple[str, ...]
    covariance: NDArray[np.float64]
    names: tuple[str, ...]
    noise_sigma: float
    noise_unit: str
    sigma_from_residuals: bool
    dof: int
    rank: int
    residuals: NDArray[np.float64] = field(repr=False)

    def to_dict(self) -> dict[str, object]:
        """JSON-ready summary (no per-sample arrays)."""
        return {
            "coefficients": {k: e.to_dict() for k, e in self.coefficients.items()},
            "combinations": [c.to_dict() for c in self.combinations],
            "not_separable": list(self.not_separable),
            "noise": {
                "sigma": self.noise_sigma,
                "unit": self.noise_unit,
                "source": "residuals" if self.sigma_from_residuals else "given",
            },
            "dof": self.dof,
            "rank": self.rank,
        }


class LinearTestResult:
    """Shared behaviour of procedure results built on an :class:`Identification`.

    A result dataclass that inherits this provides the attributes ``procedure``,
    ``site_latitude_deg``, ``site_gravity_m_s2``, ``identification``, ``residual_output``,
    ``output_unit`` and ``messages``; it gets :attr:`coefficients`, :attr:`combinations` and the
    common part of ``to_dict()`` (DESIGN.md's ``fit --json`` layout).
    """

    procedure: str
    site_latitude_deg: float
    site_gravity_m_s2: float
    identification: Identification
    residual_output: NDArray[np.float64]
    output_unit: str
    messages: tuple[str, ...]

    @property
    def coefficients(self) -> dict[str, Estimate]:
        """Individually identifiable coefficients."""
        return self.identification.coefficients

    @property
    def combinations(self) -> tuple[Combination, ...]:
        """Identifiable combinations of the rest."""
        return self.identification.combinations

    def to_dict(self) -> dict[str, object]:
        """Versioned JSON-ready dictionary; procedures add their own keys."""
        d: dict[str, object] = {"schema_version": SCHEMA_VERSION, "procedure": self.procedure}
        d["site"] = {"latitude_deg": self.site_latitude_deg, "gravity_m_s2": self.site_gravity_m_s2}
        d.update(self.identification.to_dict())
        d["residual_rms"] = {
            "value": float(np.sqrt(np.mean(self.residual_output**2))),
            "unit": self.output_unit,
        }
        d["n_observations"] = int(self.residual_output.size)
        d["messages"] = list(self.messages)
        return d
