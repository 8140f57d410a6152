"""Numbers as printed: values rounded to their uncertainty, round-off printed as zero.

One rule for every report table and terminal table (JCGM 100:2008, GUM 7.2.6): the standard
uncertainty is quoted to two significant digits and the value is rounded to the same decimal
(``y = 10.057 62 ohm`` with ``u = 27 mohm`` is printed ``10.058 ohm``); a value that is zero at
that decimal is printed as zero (``0.000 ± 0.061 deg/h``, never ``-0.000``). A number without an
uncertainty (a machine setting, a test condition) keeps four significant digits, and one that is
round-off next to its table's scale (``|x| < 1e-12 * scale``) is printed as ``0``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

#: Relative size below which a number without an uncertainty is round-off and printed as 0.
ROUND_OFF = 1e-12

#: Largest |decimal exponent| printed in fixed notation; beyond it, scientific notation.
_FIXED_MIN_EXP = -5
_FIXED_MAX_EXP = 7
#: A value of 0.1 or more keeps fixed notation down to this decimal (``1.23450046 ± 0.00000034``).
_FIXED_MIN_DEC = -10


def _finite(x: float | None) -> bool:
    return x is not None and math.isfinite(x)


def _exp10(x: float) -> int:
    """Decimal exponent of |x| > 0 (``floor(log10 |x|)``), robust at exact powers of ten."""
    e = math.floor(math.log10(abs(x)))
    if abs(x) >= 10.0 ** (e + 1):
        e += 1
    elif abs(x) < 10.0 ** e:
        e -= 1
    return e


def _fixed(x: float, decimals: int) -> str:
    """``x`` to ``decimals`` decimals (to the nearest ``10**-decimals`` when negative), no -0."""
    if decimals >= 0:
        s = f"{x:.{decimals}f}"
    else:
        s = f"{round(x, decimals):.0f}"
    if s.lstrip("-").strip("0.") == "":
        s = s.lstrip("-")
    return s


def round_to_uncertainty(value: float, std: float | None) -> tuple[str, str]:
    """``value`` and ``std`` as text, the std to two significant digits and the value to match.

    Parameters
    ----------
    value : float
        The estimate, in the unit it is printed in.
    std : float or None
        Its standard uncertainty in the same unit; ``None``, zero, negative or not finite when
        there is none (then the value keeps four significant digits, see :func:`format_number`).

    Returns
    -------
    (str, str)
        The value and the std as printed. Zero to the rounding is ``"0.000"`` (no sign); very
        large or small numbers share the std's decimal in scientific notation (``"1.234e-09"``,
        ``"5.0e-11"``; ``"-7e-08"``, ``"1.5e-07"``).

    Notes
    -----
    JCGM 100:2008 (GUM) 7.2.6: ``u`` to at most two significant digits, the estimate rounded to be
    consistent with it; ``10.057 62`` with ``u = 0.027`` gives ``("10.058", "0.027")``.
    """
    if not _finite(value):
        return str(value), "" if std is None else _std_only(std)
    if std is None or not math.isfinite(std) or std <= 0:
        return format_number(value), ("0" if std == 0 else "" if std is None else str(std))
    d = _exp10(std) - 1                         # decimal exponent of the std's 2nd digit
    if round(std, -d) >= 10.0 ** (d + 2):       # 0.0996 -> 0.10: one decade up
        d += 1
    top = max(_exp10(value) if value != 0 else d, d + 1)
    if top < _FIXED_MAX_EXP and (d >= _FIXED_MIN_EXP - 1 or top >= -1 and d >= _FIXED_MIN_DEC):
        return _fixed(value, -d), _fixed(std, -d)
    v = round(value, -d)
    if v == 0:
        return f"{0.0:.{max(_exp10(std) - d, 0)}e}", f"{std:.1e}"
    # the value's last digit at the std's second one, also when |value| < std
    return f"{v:.{max(_exp10(v) - d, 0)}e}", f"{std:.1e}"


def _std_only(std: float) -> str:
    return f"{std:.2g}" if _finite(std) else str(std)


def format_number(
    x: float, *, scale: float | None = None, digits: int = 4, round_off: float = ROUND_OFF
) -> str:
    """A number without an uncertainty to ``digits`` significant digits; round-off as ``0``.

    Parameters
    ----------
    x : float
        The number, in the unit it is printed in.
    scale : float, optional
        The table's (or quantity's) magnitude; ``|x| < ROUND_OFF * scale`` prints ``0``. Without
        it only an exact zero does.
    digits : int
        Significant digits kept.
    round_off : float
        Relative size printed as 0 (default :data:`ROUND_OFF`; larger for numbers computed by
        quadrature, whose round-off is larger than the arithmetic's).
    """
    if isinstance(x, bool) or not isinstance(x, int | float):
        return str(x)
    if not math.isfinite(x):
        return str(x)
    if x == 0 or scale is not None and abs(x) < round_off * abs(scale):
        return "0"
    if isinstance(x, int) and abs(x) < 10 ** _FIXED_MAX_EXP:
        return str(x)
    xr = float(f"{x:.{digits - 1}e}")
    e = _exp10(xr)
    if _FIXED_MIN_EXP <= e < _FIXED_MAX_EXP:
        return _fixed(xr, max(digits - 1 - e, 0))
    return f"{xr:.{digits - 1}e}"


def table_scale(values: Iterable[float]) -> float:
    """The largest finite magnitude among ``values`` (0 when none): the scale of a column."""
    mags = [abs(float(v)) for v in values if _finite(v)]
    return max(mags, default=0.0)


def format_column(values: Iterable[float], *, digits: int = 4) -> list[str]:
    """A column without uncertainties: round-off relative to the column's scale printed as 0."""
    vals = list(values)
    scale = table_scale(vals)
    return [format_number(v, scale=scale, digits=digits) for v in vals]


def format_with_std(value: float, std: float | None, unit: str = "") -> str:
    """``"value ± std unit"`` by :func:`round_to_uncertainty` (``"value unit"`` without a std)."""
    v, s = round_to_uncertainty(value, std)
    text = f"{v} ± {s}" if s and s != "0" else v
    return f"{text} {unit}".rstrip()
