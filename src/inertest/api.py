"""The Python API; it mirrors the command line (``inertest simulate``, ``inertest fit``).

Example
-------
>>> import inertest
>>> plan = inertest.load_plan("examples/polar_tumble/plan.toml")       # doctest: +SKIP
>>> data = inertest.simulate(plan, "examples/polar_tumble/truth.toml", noise=0.002, rng=1)
>>> result = inertest.fit(plan, data)                                   # doctest: +SKIP
>>> result.coefficients["DI"]                  # Estimate(name='DI', value=..., unit='deg/h/g')
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from inertest.io.data_file import read_table
from inertest.io.plan_file import load_plan as _load_plan
from inertest.io.plan_file import load_truth
from inertest.plan import Plan
from inertest.procedures import procedure

PathLike = str | os.PathLike[str]


def load_plan(path: PathLike) -> Plan:
    """Read a TOML plan file."""
    return _load_plan(path)


def load_data(path: PathLike) -> dict[str, NDArray]:
    """Read a CSV or Parquet data file into ``{column: ndarray}``."""
    return read_table(path)


def fit(
    plan: Plan | PathLike, data: Mapping[str, Any] | PathLike, *, sigma: float | None = None,
    noise_model: str | None = None,
) -> Any:
    """Identify the instrument's coefficients from the test data (``inertest fit``).

    Parameters
    ----------
    plan : Plan or path
        The test plan.
    data : mapping of columns, or path to a CSV/Parquet file
        Measurements with the columns the procedure names.
    sigma : float, optional
        Known noise per row [output unit]; estimated from the residuals when omitted.
    noise_model : str, optional
        Noise model of the instrument (``auto``, ``white``, ``position-offsets``,
        ``random-walk``, ``flicker``; :func:`inertest.estimation.identify.solve`), overriding
        the plan's ``[procedure] noise_model``; default: the plan's.

    Returns
    -------
    The procedure's result object (e.g. ``PolarTumbleResult``) with ``coefficients``,
    ``combinations``, ``to_dict()`` (:meth:`inertest.procedures.base.Procedure.fit`).
    """
    p = plan if isinstance(plan, Plan) else load_plan(plan)
    d = data if isinstance(data, Mapping) else load_data(data)
    where = "(in memory)" if isinstance(data, Mapping) else str(data)
    return procedure(p.kind).fit(p, d, sigma=sigma, noise_model=noise_model,
                                 source=f"data {where}")


def simulate(
    plan: Plan | PathLike,
    truth: Mapping[str, float] | PathLike,
    *,
    noise: float = 0.0,
    rng: np.random.Generator | int | None = None,
) -> dict[str, NDArray]:
    """Readings of a virtual instrument on the plan (``inertest simulate``).

    Parameters
    ----------
    truth : mapping or path
        True coefficients ``{name: value}`` in the procedure's engineering units (deg/h, deg/h/g,
        deg/h/g^2 for an SDF gyro), or a TOML truth file of them.
    noise : float
        White noise per reading [output unit].
    """
    p = plan if isinstance(plan, Plan) else load_plan(plan)
    t = truth if isinstance(truth, Mapping) else load_truth(truth)
    return procedure(p.kind).simulate(p, t, noise=noise, rng=rng)
