"""inertest: testing and calibration of inertial instruments.

Conventions (also in README.md)
-------------------------------
* **Units.** SI inside the library: rad, s, m, m/s^2, rad/s. Engineering units (deg/h, deg/h/g,
  ug, ppm, arcsec) only at the edges, always labelled; conversions live in :mod:`inertest.units`.
  The unit "g" is standard gravity g0 = 9.80665 m/s^2. The specific force on an instrument at rest
  has the magnitude of the site's local gravity (given in the plan, or WGS-84 normal gravity).
* **Frames.** Local level ENU (x east, y north, z up); platform P; body b; instrument axes I
  (input), O (output), S (spin reference) of an SDF gyro with I x O = S. ``C_ab`` maps vectors
  from frame b to frame a; vectors are named ``vec_frame``. Rotations use
  :class:`scipy.spatial.transform.Rotation` (scalar-last quaternions, as scipy).
* **Earth.** Rate 7.2921151467e-5 rad/s (WGS-84); ENU components ``(0, W cos L, W sin L)``.
  An instrument at rest feels specific force ``+g`` along up.
* **Signs.** Gyro drift adds to the true rate: ``w_out = w_I + drift``; accelerometer bias adds
  to the true specific force. Torque-feedback output ``S_T * i = w_I + drift``.
* **SDF gyro static drift model** (f in g, i.e. specific force divided by g0)::

      drift = DF + DI fI + DO fO + DS fS + DIO fI fO + DOS fO fS + DSI fS fI
                 + DII fI^2 + DOO fO^2 + DSS fS^2

  Coefficients are held in rad/s per g^k inside, reported in deg/h, deg/h/g, deg/h/g^2.
* **IMU triads** (one model, :mod:`inertest.models.triad`): ``raw = K (I + M) u + b [+ G a]``.
  ``M_ij`` is the sensitivity of sensor i (first index) to the input along / about reference
  axis j (second index), ``M_ij = S_ij / S_ii``, in urad. Scale factor ``K_i``: raw output per
  unit input -- accelerometers per (m/s^2); gyros per (deg/s) of the raw *rate reading*, so a
  digital reading gives count/(deg/s) and a pulse output (count/s) gives count/deg, the same
  number; ``1`` (with a ppm deviation) when the raw output is already a physical unit. The bias
  adds to the output; it is reported input-referred, ``B = S^-1 b``, in mg or deg/h (positive:
  the sensor reads high). A negative ``K_i`` is an axis mounted reversed.
"""

from __future__ import annotations

import importlib
from typing import Any

#: Public names and the module that defines them, imported on first use so that
#: ``import inertest`` (and ``inertest --help``) does not load scipy, plotting or databases.
_PUBLIC = {
    "fit": "inertest.api",
    "simulate": "inertest.api",
    "load_plan": "inertest.api",
    "load_data": "inertest.api",
    "run": "inertest.app.run",
    "run_batch": "inertest.app.batch",
    "RunOutcome": "inertest.app.run",
}

__all__ = sorted(_PUBLIC)
__version__ = "0.1.0"


def __getattr__(name: str) -> Any:
    module = _PUBLIC.get(name)
    if module is None:
        raise AttributeError(f"module 'inertest' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_PUBLIC])
