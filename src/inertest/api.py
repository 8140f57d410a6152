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

from inertest.errors import InputError
from inertest.io.frames import columns_of, is_frame
from inertest.io.plan_file import load_plan as _load_plan
from inertest.io.plan_file import load_truth
from inertest.plan import Plan
from inertest.procedures import procedure

PathLike = str | os.PathLike[str]
#: What ``data`` may be: a path, a pandas DataFrame, a pyarrow Table, a mapping of arrays.
Data = Any


def load_plan(path: PathLike) -> Plan:
    """Read a TOML plan file."""
    return _load_plan(path)


def load_data(
    data: Data, topic: str | None = None, *, layout: PathLike | None = None,
) -> dict[str, NDArray]:
    """Columns of a data file or an in-memory table, as ``{column: ndarray}``.

    Parameters
    ----------
    data : path, pandas.DataFrame, pyarrow.Table or mapping of arrays
        CSV, Parquet, HDF5; ROS 1 bag, ROS 2 bag folder, MCAP, SQLite3 (``.db3``), PX4 ULog,
        LabVIEW TDMS, whitespace/tab text table, or binary records with ``layout``
        (:func:`inertest.io.recordings.read_data`); or a table already in memory.
    topic : str, optional
        ROS topic, ULog message (``vehicle_imu:1`` for an instance) or TDMS group; default
        the IMU topic found by its type, or the only one.
    layout : path, optional
        TOML record layout of a binary file (:mod:`inertest.io.recordings.binary_layout`).

    Examples
    --------
    >>> cols = inertest.load_data("flight.ulg")                       # doctest: +SKIP
    >>> cols = inertest.load_data("imu.bag", topic="/imu")            # doctest: +SKIP
    >>> cols = inertest.load_data(pandas.read_csv("session.csv"))     # doctest: +SKIP
    """
    if isinstance(data, str | os.PathLike):
        from inertest.io.recordings import read_data

        return read_data(data, topic=topic, layout=layout)
    if topic is not None or layout is not None:
        raise InputError("topic and layout are for data files (ROS bags, ULog, TDMS, binary "
                         "records); an in-memory table has neither")
    return columns_of(data)


def _columns(data: Data) -> tuple[dict[str, NDArray] | Mapping[str, Any], str]:
    """The columns of ``data`` and how messages name it."""
    if isinstance(data, Mapping) and not is_frame(data):
        return data, "(in memory)"
    if isinstance(data, str | os.PathLike):
        return load_data(data), str(data)
    return columns_of(data), f"({type(data).__name__} in memory)"


def fit(
    plan: Plan | PathLike, data: Data, *, sigma: float | None = None,
    noise_model: str | None = None,
) -> Any:
    """Identify the instrument's coefficients from the test data (``inertest fit``).

    Parameters
    ----------
    plan : Plan or path
        The test plan.
    data : path, pandas.DataFrame, pyarrow.Table or mapping of arrays
        Measurements with the columns the procedure names (any file :func:`load_data` reads).
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
    d, where = _columns(data)
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
