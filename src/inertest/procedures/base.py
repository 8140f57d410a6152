"""The procedure as a type: the chain plan -> motion -> reduction -> identification, written once.

Every test procedure is a subclass of :class:`Procedure` that declares what it is (its ``kind``,
its parameter class, its error model, its identification method, the machines whose Type-B
errors apply, its choice of noise models) and implements four steps:

``motion(plan, type_b=...)``
    The test equipment's kinematics at the plan's site (:mod:`inertest.equipment`): a machine
    that gives the instrument's attitude, angular rate and specific force for each labelled
    segment (position, rate, run, turn). ``type_b`` applies the equipment's Type-B errors (a
    perturbed machine, :mod:`inertest.equipment.type_b`); None for a test without a known
    motion (the orientation-free calibration finds its attitudes in the data).
``reduce(plan, data, motion)``
    Reads and checks the data columns and turns them into the procedure's observations with
    their inputs (per-row or per-segment means, whole-cycle integrals, static intervals).
``identify(plan, observations, sigma=..., noise_model=...)``
    Identification (weighted least squares under a noise model, a closed form, or Gauss-Newton
    for the nonlinear procedures) and the procedure's result: an
    :class:`~inertest.results.Identification` inside a frozen result whose ``to_dict()`` is
    the result envelope.
``synthesize(plan, motion, truth, noise=..., rng=...)``
    The instrument's readings over the motion from its error model with true coefficients
    (a virtual instrument), in the data columns that ``reduce`` reads.

:meth:`Procedure.fit` and :meth:`Procedure.simulate` are written here once over those steps:
the checks of the options (``sigma``, ``noise_model``), the plan's sample rate against the data's
clock, and the instrument under test on the result. ``simulate`` takes a given motion, so the
uncertainty budget simulates the test on a perturbed machine and fits it with the nominal one
(:mod:`inertest.quality.budget`).
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from collections.abc import Mapping
from types import ModuleType
from typing import Any, ClassVar, Generic, Protocol, TypeVar

import numpy as np
from numpy.typing import NDArray

from inertest.errors import PlanError
from inertest.plan import Plan

SpecT = TypeVar("SpecT")
ObsT = TypeVar("ObsT")
ResultT = TypeVar("ResultT")

#: What a plan's Type-B errors look like inside the library: ``{source name: error [SI]}``.
TypeBErrors = Mapping[str, float]


class SpecClass(Protocol):
    """What :attr:`Procedure.spec` is: a class built from a plan's ``[procedure]`` table."""

    def from_mapping(self, params: Mapping[str, object], /) -> Any:
        """The procedure's parameters, each field read by :func:`inertest.plan.read_fields`."""
        ...


class Procedure(ABC, Generic[SpecT, ObsT, ResultT]):
    """One test procedure (a subclass per test; instances carry no state).

    Class attributes
    ----------------
    kind : str
        The ``[procedure] kind`` of plan files.
    title : str
        What a test engineer calls it.
    spec : type
        Its ``[procedure]`` parameter class (``spec.from_mapping(params)``, fields read by
        :func:`inertest.plan.read_fields`).
    model : str
        The error model it identifies (the module of :mod:`inertest.models`).
    method : str
        How it identifies the model (``"weighted least squares"``, ``"closed form"``,
        ``"Gauss-Newton"``, ...), for the architecture page and reports.
    machines : tuple of module
        The equipment modules whose ``TYPE_B`` sources apply to its motion (the uncertainty
        budget's Type-B sources; empty when the motion carries none).
    noise_models : tuple of str
        The noise models a user may choose (``noise_model`` of the plan, ``--noise-model``);
        empty when the procedure has no choice.
    sigma_note : str or None
        Why the procedure takes no known noise level (``sigma``), or None when it does.
    report : str or None
        ``"module:function"`` building its report sections; None for the generic ones.
    """

    kind: ClassVar[str]
    title: ClassVar[str]
    spec: ClassVar[SpecClass]
    model: ClassVar[str]
    method: ClassVar[str]
    machines: ClassVar[tuple[ModuleType, ...]] = ()
    noise_models: ClassVar[tuple[str, ...]] = ()
    sigma_note: ClassVar[str | None] = None
    report: ClassVar[str | None] = None

    # -- the steps each procedure implements ------------------------------------------------

    def motion(self, plan: Plan, *, type_b: TypeBErrors | None = None) -> Any:
        """The equipment's kinematics for ``plan`` (with Type-B errors ``type_b`` [SI])."""
        return None

    @abstractmethod
    def reduce(self, plan: Plan, data: Mapping[str, object], motion: Any) -> ObsT:
        """The observations of ``data`` with their inputs from ``motion``."""

    @abstractmethod
    def identify(self, plan: Plan, obs: ObsT, *, sigma: float | None,
                 noise_model: str | None) -> ResultT:
        """Identify the error model from the observations: the procedure's result."""

    @abstractmethod
    def synthesize(self, plan: Plan, motion: Any, truth: Mapping[str, float], *,
                   noise: float, rng: np.random.Generator | int | None) -> dict[str, NDArray]:
        """Readings of a virtual instrument with ``truth`` over ``motion`` (data columns)."""

    def truth_quantities(self, truth: Mapping[str, float]) -> dict[str, float]:
        """The truth extended by the derived quantities the result reports (default: as is)."""
        return dict(truth)

    # -- written once -------------------------------------------------------------------------

    def fit(self, plan: Plan, data: Mapping[str, object], *, sigma: float | None = None,
            noise_model: str | None = None, motion: Any = None,
            source: str = "data (in memory)") -> ResultT:
        """Identify the instrument's coefficients from the test data.

        Parameters
        ----------
        plan : Plan
            The test plan (site, instrument, this procedure's parameters).
        data : mapping of column name to array
            The measurements, in the columns :meth:`reduce` names.
        sigma : float, optional
            Known white noise per reading [output unit]; estimated from the residuals when
            omitted.
        noise_model : str, optional
            Overrides the plan's ``[procedure] noise_model`` (one of :attr:`noise_models`).
        motion : optional
            The machine to take the inputs from; default :meth:`motion` of the plan.
        source : str
            How messages name the data (``"data tumble.csv"``).

        Returns
        -------
        The procedure's result, with the plan's instrument.
        """
        model = self._noise_model(plan, noise_model)
        if sigma is not None and self.sigma_note is not None:
            raise PlanError(f"{self.kind} {self.sigma_note}; do not give sigma")
        rate = getattr(plan.procedure, "sample_rate_hz", None)
        if isinstance(rate, int | float) and not isinstance(rate, bool):
            from inertest.procedures.spec import check_sample_rate

            # A plan's sample rate that the data's own clock contradicts scales every integral.
            check_sample_rate(data, float(rate), source=source)  # type: ignore[arg-type]
        obs = self.reduce(plan, data, self.motion(plan) if motion is None else motion)
        result = self.identify(plan, obs, sigma=sigma, noise_model=model)
        if dataclasses.is_dataclass(result) and any(
                f.name == "instrument" for f in dataclasses.fields(result)):
            # The result envelope names the instrument under test (``to_dict()["instrument"]``).
            result = dataclasses.replace(result, instrument=plan.instrument)  # type: ignore[type-var]
        return result

    def simulate(self, plan: Plan, truth: Mapping[str, float], *, noise: float = 0.0,
                 rng: np.random.Generator | int | None = None,
                 motion: Any = None) -> dict[str, NDArray]:
        """Readings of a virtual instrument on the plan's test.

        Parameters
        ----------
        plan : Plan
            The test plan.
        truth : mapping
            True coefficients by name in the procedure's engineering units; missing names 0.
        noise : float
            White noise per reading [output unit].
        rng : Generator, int or None
            Random source for the noise.
        motion : optional
            The machine the test runs on; default :meth:`motion` of the plan (give a perturbed
            one, ``self.motion(plan, type_b=...)``, to simulate equipment errors).
        """
        return self.synthesize(plan, self.motion(plan) if motion is None else motion, truth,
                               noise=noise, rng=rng)

    def _noise_model(self, plan: Plan, override: str | None) -> str | None:
        """The noise model to use: the override, else the plan's; None without a choice."""
        if not self.noise_models:
            if override is not None:
                raise PlanError(f"the {self.kind} procedure has no choice of noise model; got "
                                f"noise_model={override!r}: leave it out")
            return None
        value = override if override is not None else getattr(plan.procedure, "noise_model",
                                                               "auto")
        if not isinstance(value, str) or value not in self.noise_models:
            raise PlanError(f"noise_model must be one of {', '.join(self.noise_models)}, got "
                            f"{value!r}")
        return value

    def __repr__(self) -> str:
        return f"<procedure {self.kind}>"
