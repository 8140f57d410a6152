"""Result types shared by the procedures: estimates and combinations with their units."""

from __future__ import annotations

import functools
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from inertest.earth import Site
from inertest.plan import Instrument

#: Version of the JSON layout written by ``to_dict`` methods; bump on incompatible change.
SCHEMA_VERSION = 2


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
class Outlier:
    """A unit of independence (position, run, reading) whose residual the noise model rejects.

    Attributes
    ----------
    label : str
        The unit, as the data name it (e.g. ``"O-Sp 22.5 deg"``, ``"rate -30 deg/s"``).
    z : float
        Standardised residual (whitened by the noise model, leverage-corrected) [1].
    """

    label: str
    z: float

    def to_dict(self) -> dict[str, object]:
        """``{"label", "z"}``."""
        return {"label": self.label, "z": self.z}


@dataclass(frozen=True)
class ModelChecks:
    """Goodness of fit of the model, with its noise model, to the data.

    Residuals are reduced to the natural unit of independence (a position or run: the mean of
    its readings) and whitened by the covariance of the noise model, so that under the model
    they are independent N(0, 1) apart from the fitted directions.

    Attributes
    ----------
    name : str
        ``"noise model fit"``.
    noise_model : str
        Noise model used (``white``, ``position-offsets``, ``random-walk``, ``flicker``).
    unit : str
        Unit of independence: ``"position"`` (rows grouped by position/run) or ``"reading"``.
    n_units : int
        Number of units.
    statistic : str
        What :attr:`chi_square` measures.
    chi_square : float
        Sum of squared whitened unit residuals, or ``dof * F`` of the lack-of-fit test when the
        noise level comes from the scatter within positions [1].
    dof : int
        Its degrees of freedom.
    p_value : float or None
        Probability of a larger value under the model; None when the noise level was fitted
        to these same residuals (then the sum is ``dof`` by construction and tests nothing).
    serial_chi_square, serial_dof, serial_p_value : float, int, float or None
        Ljung-Box portmanteau statistic of the whitened residuals in time order (Ljung & Box,
        Biometrika 65(2), 1978, doi:10.1093/biomet/65.2.297): systematic misfit (a wrong
        label, a missing term) and unmodelled drift make neighbouring residuals alike. None
        with fewer than 10 units.
    outliers : tuple of Outlier
        Units with ``|z|`` above :attr:`outlier_threshold`.
    outlier_threshold : float
        ``max(4, Phi^-1(1 - alpha / (2 n_units)))`` (Bonferroni, a Grubbs-like rule) [1].
    alpha : float
        Significance level of the tests.
    verdict : str
        ``"consistent"`` or ``"model does not fit"``.
    shift_units, shift_f, shift_dof, shift_p_value : tuple of str, float, (int, int), float
        The one or two units whose own free mean most improves the fit, its F statistic
        against the scatter of the other units (numerator and denominator dof) and the
        Bonferroni p-value over every unit and pair (mean-shift outlier test). A ratio of parts
        of the same residuals, it tests even when the noise level (and a fitted variance
        component) came from them; empty / None with too few dof.
    plausibility : str or None
        Why a fitted noise component is implausible (a position offset far above the noise
        within positions: a misfit absorbed as noise), else None.
    message : str or None
        The warning when the model does not fit (why, and what to check), else None; the
        result envelope repeats it in its ``messages`` (:func:`envelope`).
    """

    noise_model: str
    unit: str
    n_units: int
    statistic: str
    chi_square: float
    dof: int
    p_value: float | None
    serial_chi_square: float | None
    serial_dof: int
    serial_p_value: float | None
    outliers: tuple[Outlier, ...]
    outlier_threshold: float
    alpha: float
    verdict: str
    shift_units: tuple[str, ...] = ()
    shift_f: float | None = None
    shift_dof: tuple[int, int] = (0, 0)
    shift_p_value: float | None = None
    plausibility: str | None = None
    message: str | None = None
    name: str = "noise model fit"

    @property
    def fits(self) -> bool:
        """True when the verdict is ``"consistent"``."""
        return self.verdict == "consistent"

    def to_dict(self) -> dict[str, object]:
        """JSON-ready block (``checks`` of the result)."""
        return {
            "name": self.name,
            "verdict": self.verdict,
            "noise_model": self.noise_model,
            "unit": self.unit,
            "n_units": self.n_units,
            "goodness_of_fit": {
                "statistic": self.statistic,
                "chi_square": _finite_or_none(self.chi_square),
                "dof": self.dof,
                "p_value": _finite_or_none(self.p_value),
            },
            "serial_correlation": {
                "statistic": "Ljung-Box",
                "chi_square": _finite_or_none(self.serial_chi_square),
                "dof": self.serial_dof,
                "p_value": _finite_or_none(self.serial_p_value),
            },
            "outliers": [o.to_dict() for o in self.outliers],
            "outlier_threshold": self.outlier_threshold,
            "mean_shift": {
                "statistic": "F of a free mean for the one or two units that most improve the "
                             "fit, against the scatter of the other units (Bonferroni over "
                             "every unit and pair)",
                "units": list(self.shift_units),
                "F": _finite_or_none(self.shift_f),
                "dof": list(self.shift_dof),
                "p_value": _finite_or_none(self.shift_p_value),
            },
            "plausibility": self.plausibility,
            "alpha": self.alpha,
            "message": self.message,
        }


#: Rows per block of :func:`sum_of_squares` (512 KB of float64: a temporary that stays in cache).
_SQUARES_BLOCK = 1 << 16


def sum_of_squares(
    x: NDArray[np.float64],
    minus: NDArray[np.float64] | None = None,
    index: NDArray[np.intp] | None = None,
) -> float:
    """``sum((x - minus[index])**2)`` (``sum(x**2)`` without ``minus``), a block at a time.

    The same pairwise sums as numpy within each block, without the record-length temporaries of
    the whole expression (three arrays of 80 MB at 1e7 rows, each fresh memory to fault in).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Values (e.g. readings or residuals).
    minus : ndarray, shape (G,), optional
        Value subtracted from each row, ``minus[index[i]]`` from ``x[i]`` (e.g. unit means).
    index : ndarray of int, shape (n,), optional
        Entry of ``minus`` for each row; required with ``minus``.
    """
    total = 0.0
    for i in range(0, x.size, _SQUARES_BLOCK):
        blk = x[i:i + _SQUARES_BLOCK]
        if minus is not None:
            assert index is not None
            blk = blk - minus[index[i:i + _SQUARES_BLOCK]]
        total += float(np.sum(np.square(blk)))
    return total


def _finite_or_none(x: float | None) -> float | None:
    """JSON has no NaN: a missing or undefined number is ``null``."""
    return None if x is None or not np.isfinite(x) else float(x)


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
        White noise per observation [noise_unit], estimated from the residuals unless given
        (then the given value).
    noise_unit : str
    sigma_from_residuals : bool
    dof : int
        Residual degrees of freedom.
    rank : int
        Rank of the design (number of independent quantities determined).
    residuals : ndarray
        Observation minus model [noise_unit].
    noise_model : str
        Noise model behind the uncertainties (``white``, ``position-offsets``, ``random-walk``,
        ``flicker``; see :mod:`inertest.estimation.identify`).
    noise_components : dict
        Standard deviation of each component of the noise model [noise_unit]: ``white`` (per
        reading), ``position offset`` (per position), ``random walk`` (step per reading),
        ``flicker`` (per reading).
    checks : ModelChecks or None
        Goodness of fit of the model and its noise model (None when not computed).
    noise_model_weights : dict
        With ``noise_model = "auto"``: the Akaike weight of each candidate noise model;
        :attr:`noise_model` has the largest, and the models within 2 AIC of it (weight at
        least ``exp(-1)`` of its own, listed as ``close`` in the JSON) add the spread of their
        estimates to the covariance (:func:`inertest.estimation.identify.solve`). Empty
        otherwise.
    bias_time_scale : float or None
        When flicker noise is behind the covariance: the time over which the std of the
        constant (bias-type) terms holds, in test durations (the bias averaged over that time
        around the test; default 2, about the bias during this test). For 1/f noise the
        variance of a mean grows with the averaging time, so over a longer time the bias
        wanders further, by about the bias instability. None otherwise.
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
    noise_model: str = "white"
    noise_components: Mapping[str, float] = field(default_factory=dict)
    checks: ModelChecks | None = None
    noise_model_weights: Mapping[str, float] = field(default_factory=dict)
    bias_time_scale: float | None = None

    def rows(self) -> list[dict[str, object]]:
        """One row per coefficient, then per combination: name, kind, value, std, unit, terms."""
        out: list[dict[str, object]] = [
            {"name": k, "kind": "coefficient", "value": e.value, "std": e.std, "unit": e.unit,
             "terms": {k: 1.0}} for k, e in self.coefficients.items()]
        out += [{"name": c.name, "kind": "combination", "value": c.value, "std": c.std,
                 "unit": c.unit, "terms": dict(c.terms)} for c in self.combinations]
        return out

    def to_pandas(self) -> object:
        """What the data determine as a ``pandas.DataFrame`` indexed by name.

        Columns ``kind`` (coefficient or combination), ``value``, ``std`` (1 sigma), ``unit``
        and ``terms`` (the weights of a combination; ``{name: 1}`` for a coefficient).
        """
        from inertest.errors import import_extra

        pd = import_extra("pandas", "to_pandas()")
        return pd.DataFrame(self.rows()).set_index("name")  # type: ignore[attr-defined]

    def covariance_to_pandas(self) -> object:
        """The covariance of the coefficients as a ``pandas.DataFrame``, names on both axes.

        In the coefficients' engineering units (``attrs["units"]``: name -> unit); meaningful
        only along identifiable directions (the combinations).
        """
        from inertest.errors import import_extra

        pd = import_extra("pandas", "covariance_to_pandas()")
        names = list(self.names)
        df = pd.DataFrame(np.asarray(self.covariance), index=names,  # type: ignore[attr-defined]
                          columns=names)
        df.attrs["units"] = {k: e.unit for k, e in self.coefficients.items()}
        return df

    def to_dict(self) -> dict[str, object]:
        """JSON-ready summary (no per-sample arrays); the checks under ``"checks"``."""
        d: dict[str, object] = {
            "coefficients": {k: e.to_dict() for k, e in self.coefficients.items()},
            "combinations": [c.to_dict() for c in self.combinations],
            "not_separable": list(self.not_separable),
            "noise": {
                "sigma": _finite_or_none(self.noise_sigma),
                "unit": self.noise_unit,
                "source": "residuals" if self.sigma_from_residuals else "given",
                "model": self.noise_model,
                "components": {
                    k: _finite_or_none(v) for k, v in self.noise_components.items()
                },
            },
            "dof": self.dof,
            "rank": self.rank,
        }
        if self.noise_model_weights:
            noise = d["noise"]
            assert isinstance(noise, dict)
            top = max(self.noise_model_weights.values())
            noise["selection"] = {
                "rule": "auto: white noise unless a correlated model beats it by the "
                        "likelihood-ratio test (restricted likelihood, boundary corrected, "
                        "5 % for the family), else the correlated model of smallest AIC; its "
                        "covariance plus the spread of the estimates of the models within 2 "
                        "of it per output (close), with the Akaike weights of that criterion",
                "weights": {k: float(v) for k, v in self.noise_model_weights.items()},
                "close": [k for k, v in self.noise_model_weights.items()
                          if v >= top * np.exp(-1.0) * (1 - 1e-12)],
            }
        if self.bias_time_scale is not None:
            noise = d["noise"]
            assert isinstance(noise, dict)
            noise["bias_time_scale"] = {
                "value": float(self.bias_time_scale), "unit": "test durations",
                "meaning": "under flicker (1/f) noise the std of the constant (bias-type) "
                           "terms is that of their mean over this time around the test "
                           "(flicker from 1/(2 x this x the test's duration)); the bias "
                           "wanders further over longer times, by about the bias "
                           "instability (plan key bias_time_scale)",
            }
        if self.checks is not None:
            d["checks"] = self.checks.to_dict()
        return d


@dataclass(frozen=True, kw_only=True)
class LinearTestResult:
    """The fields and behaviour every procedure result shares, built on an :class:`Identification`.

    A procedure's frozen result dataclass inherits this and adds its own fields and a
    ``procedure: str = KIND`` field; it gets :attr:`kind`, :attr:`coefficients`,
    :attr:`combinations` and ``to_dict()`` (the :func:`envelope`), and overrides
    :meth:`details` for its own block. The shared fields are keyword-only.

    Attributes
    ----------
    site_latitude_deg, site_gravity_m_s2 : float
        Where the test ran [deg], [m/s^2].
    identification : Identification
        What the data determine.
    residual_output : ndarray
        Residuals in the output unit.
    output_unit : str
        Unit of the recorded output (and of the residuals).
    messages : tuple of str
        Notes and warnings for the user.
    instrument : Instrument or None
        The instrument under test (set by :func:`inertest.fit`).
    """

    if TYPE_CHECKING:
        procedure: str

    site_latitude_deg: float
    site_gravity_m_s2: float
    identification: Identification
    residual_output: NDArray[np.float64] = field(repr=False)
    output_unit: str
    messages: tuple[str, ...] = ()
    instrument: Instrument | None = None

    @property
    def kind(self) -> str:
        """The procedure kind (``[procedure] kind`` of the plan)."""
        return self.procedure

    @property
    def coefficients(self) -> dict[str, Estimate]:
        """Individually identifiable coefficients."""
        return self.identification.coefficients

    @property
    def combinations(self) -> tuple[Combination, ...]:
        """Identifiable combinations of the rest."""
        return self.identification.combinations

    def details(self) -> dict[str, object]:
        """The procedure's own block (``result`` in the envelope); empty by default."""
        return {}

    def to_pandas(self) -> object:
        """Coefficients and combinations as a DataFrame (:meth:`Identification.to_pandas`)."""
        return self.identification.to_pandas()

    def covariance_to_pandas(self) -> object:
        """Named covariance as a DataFrame (:meth:`Identification.covariance_to_pandas`)."""
        return self.identification.covariance_to_pandas()

    def to_dict(self) -> dict[str, object]:
        """The result :func:`envelope` with the identification and the procedure's block."""
        ident = self.identification.to_dict()
        checks = ident.pop("checks", [])
        ident["residual_rms"] = {
            "value": float(np.sqrt(sum_of_squares(self.residual_output)
                                   / max(self.residual_output.size, 1)))
            if self.residual_output.size else float("nan"),
            "unit": self.output_unit,
        }
        ident["n_observations"] = int(self.residual_output.size)
        return envelope(
            self.procedure,
            site={"latitude_deg": self.site_latitude_deg, "gravity_m_s2": self.site_gravity_m_s2},
            instrument=instrument_block(self.instrument),
            identification=ident,
            result=self.details(),
            checks=checks if isinstance(checks, list) else [checks],  # type: ignore[list-item]
            messages=self.messages,
        )


#: Top-level keys of a result's JSON, in order (:func:`envelope`); the keys of
#: :data:`OPTIONAL_KEYS` are present only when known, the others always.
ENVELOPE_KEYS: tuple[str, ...] = (
    "kind", "schema_version", "site", "instrument", "test", "identification", "result",
    "uncertainty_budget", "conformance", "checks", "messages",
)

#: Envelope keys present only when known: the test's identity (``inertest fit --equipment``),
#: the uncertainty budget (:meth:`inertest.quality.budget.UncertaintyBudget.to_dict`) and the
#: verdicts against a specification (:meth:`inertest.quality.conformance.Conformance.to_dict`).
OPTIONAL_KEYS: frozenset[str] = frozenset({"test", "uncertainty_budget", "conformance"})


@dataclass(frozen=True)
class EnvelopeResult:
    """A result carried as its envelope alone: what a batch worker sends back.

    The full result's per-sample arrays (residuals, reductions; megabytes for a long record)
    stay where the fit ran; the envelope holds everything filed, printed and judged: the
    identification with its uncertainties, the checks, the kind's own block. It travels as
    JSON text (a string is copied, not rebuilt, when it crosses to another process) and is
    parsed when first read.

    Attributes
    ----------
    text : str
        The result envelope (:func:`envelope`; the result's ``to_dict()``) as JSON, NaN and
        infinities written as such.
    kind : str
        The result's kind (a procedure kind or an analysis), read from ``text`` when not given:
        filing needs it, and parsing the whole envelope for it cost the batch's driver 0.9 ms
        a run.
    """

    text: str
    kind: str = ""

    def __post_init__(self) -> None:
        if not self.kind:
            object.__setattr__(self, "kind", str(self.doc["kind"]))

    @classmethod
    def of(cls, result: Any) -> EnvelopeResult:
        """The envelope of ``result`` (anything with ``to_dict()``)."""
        doc = result.to_dict()
        return cls(json.dumps(doc, allow_nan=True), str(doc["kind"]))

    @functools.cached_property
    def doc(self) -> dict[str, Any]:
        """The envelope, parsed (once)."""
        return dict(json.loads(self.text))

    def _identification(self) -> Mapping[str, Any]:
        ident = self.doc.get("identification")
        return ident if isinstance(ident, Mapping) else {}

    @property
    def coefficients(self) -> dict[str, Estimate]:
        """The coefficients the data determine, in engineering units."""
        found = self._identification().get("coefficients") or {}
        return {k: Estimate(k, float(e["value"]), float(e["std"]), str(e["unit"]))
                for k, e in found.items()}

    @property
    def combinations(self) -> tuple[Combination, ...]:
        """The identifiable combinations."""
        found = self._identification().get("combinations") or []
        return tuple(Combination(str(c["name"]), dict(c["terms"]), float(c["value"]),
                                 float(c["std"]), str(c["unit"])) for c in found)

    def to_dict(self) -> dict[str, object]:
        """The envelope (a fresh copy: changing it leaves this result as it was)."""
        return dict(json.loads(self.text))

    def __getstate__(self) -> dict[str, Any]:  # the text travels, not the parsed copy
        return {"text": self.text, "kind": self.kind}


def envelope(
    kind: str,
    *,
    site: Mapping[str, object] | None = None,
    instrument: Mapping[str, object] | None = None,
    identification: Mapping[str, object] | None = None,
    result: Mapping[str, object] | None = None,
    checks: Sequence[Mapping[str, object]] = (),
    messages: Sequence[str] = (),
    test: Mapping[str, object] | None = None,
    uncertainty_budget: Mapping[str, object] | None = None,
    conformance: Mapping[str, object] | None = None,
) -> dict[str, object]:
    """The one JSON layout of every inertest result (``--json`` of every command).

    Parameters
    ----------
    kind : str
        What produced it: a procedure kind (``"polar-tumble"``) or an analysis (``"allan"``,
        ``"ins-errors"``, ``"modulation-system"``, ``"centrifuge-study"``, ``"history"``, ...).
    site : mapping, optional
        ``{"latitude_deg", "gravity_m_s2", ...}`` where the result depends on a site.
    instrument : mapping, optional
        ``{"kind", "serial", "output_unit", "scale_factor"}`` of the instrument under test.
    identification : mapping, optional
        What the data determine (:meth:`Identification.to_dict`): ``coefficients`` ``{NAME:
        {"value", "std", "unit"}}``, ``combinations``, ``not_separable``, ``noise``, ``dof``.
    result : mapping, optional
        The kind's own block (harmonics, calibration, deviations, time histories, ...).
    checks : sequence of mapping
        Self-checks of the result, each ``{"name", "verdict", ...}``.
    messages : sequence of str
        Notes and warnings in plain language; the ``message`` of each check whose verdict is
        not ``consistent``/``ok`` (a model that does not fit the data) is added to them.
    test : mapping, optional
        Who ran the test, when, with what equipment (ids, calibration due dates) and in which
        environment, the software version and the data's SHA-256 (:func:`inertest.quality.lab.
        identity_block`); the key is present only when known, right after ``instrument``.
    uncertainty_budget : mapping, optional
        Per quantity: the Type-A std and its dof, each Type-B source's contribution, the
        combined std, k and the expanded U, with the independence assumption (JCGM 100:2008,
        GUM 5.1.2, G.4.1; :meth:`inertest.quality.budget.UncertaintyBudget.to_dict`); present only
        when computed, after ``result``.
    conformance : mapping, optional
        Verdict per limited quantity (value, U, k, limit, clause, verdict) and the decision
        rule's text (ILAC-G8:09/2019; :meth:`inertest.quality.conformance.Conformance.to_dict`);
        present only when a specification was given, after ``uncertainty_budget``.

    Returns
    -------
    dict
        Keys :data:`ENVELOPE_KEYS` in that order, the :data:`OPTIONAL_KEYS` only when given;
        every number inside carries its unit beside it.
    """
    doc: dict[str, object] = {
        "kind": kind,
        "schema_version": SCHEMA_VERSION,
        "site": None if site is None else dict(site),
        "instrument": None if instrument is None else dict(instrument),
        "identification": None if identification is None else dict(identification),
        "result": {} if result is None else dict(result),
        "checks": [dict(c) for c in checks],
        "messages": [str(m) for m in messages],
    }
    lifted = doc["messages"]
    assert isinstance(lifted, list)
    for c in checks:
        note = c.get("message")
        if (isinstance(note, str) and note and c.get("verdict") not in ("consistent", "ok")
                and note not in lifted):
            lifted.append(note)
    return with_blocks(doc, test=test, uncertainty_budget=uncertainty_budget,
                       conformance=conformance)


def read_envelope(doc: object, *, source: str) -> dict[str, object]:
    """An envelope read back (a result file, a stored run), checked: the one schema check.

    Parameters
    ----------
    doc : object
        The parsed JSON.
    source : str
        How messages name where it came from (``"calibration file cal.json"``).

    Returns
    -------
    dict
        The envelope.

    Raises
    ------
    InputError
        Not an inertest result envelope, or a schema version this inertest does not read
        (with what to do).
    """
    from inertest.errors import InputError

    if not isinstance(doc, Mapping) or not isinstance(doc.get("kind"), str):
        raise InputError(f"{source} is not an inertest result (a JSON object with kind and "
                         "schema_version, as --json prints)")
    version = doc.get("schema_version")
    if version != SCHEMA_VERSION:
        raise InputError(
            f"{source} has schema_version {version!r}; this inertest reads version "
            f"{SCHEMA_VERSION}: refit the data with this version (or use the inertest that "
            "wrote it)")
    return dict(doc)


def with_blocks(
    doc: Mapping[str, object],
    *,
    test: Mapping[str, object] | None = None,
    uncertainty_budget: Mapping[str, object] | None = None,
    conformance: Mapping[str, object] | None = None,
) -> dict[str, object]:
    """``doc`` (an envelope) with its optional blocks set, each in its :data:`ENVELOPE_KEYS` place.

    Parameters
    ----------
    doc : mapping
        A result envelope.
    test, uncertainty_budget, conformance : mapping, optional
        The :data:`OPTIONAL_KEYS` blocks (see :func:`envelope`); None keeps what ``doc`` has.
    """
    merged = dict(doc)
    for key, block in (("test", test), ("uncertainty_budget", uncertainty_budget),
                       ("conformance", conformance)):
        if block is not None:
            merged[key] = dict(block)
    out: dict[str, object] = {k: merged[k] for k in ENVELOPE_KEYS if k in merged}
    out.update({k: v for k, v in merged.items() if k not in out})  # foreign keys last
    return out


def instrument_block(instrument: Instrument | None) -> dict[str, object] | None:
    """``{"kind", "serial", "output_unit", "scale_factor"}`` of a plan's instrument."""
    if instrument is None:
        return None
    return {
        "kind": instrument.kind,
        "serial": instrument.serial,
        "output_unit": instrument.output_unit,
        "scale_factor": instrument.scale_factor,
    }


def site_block(site: Site) -> dict[str, object]:
    """``{"latitude_deg", "gravity_m_s2"}`` of a site."""
    return {"latitude_deg": float(np.degrees(site.latitude_rad)), "gravity_m_s2": site.gravity_m_s2}
