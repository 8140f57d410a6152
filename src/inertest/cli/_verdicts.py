"""One-line overall verdict of a result's ``conformance`` block (``batch``, ``demo``)."""

from __future__ import annotations

import re
from collections.abc import Mapping

from inertest.errors import UnitError
from inertest.units import convert

_NUM = r"([-+0-9.eE]+|[-+]?inf)"
_MAX_ABS = re.compile(rf"^\|.+\| <= {_NUM} (.+)$")
_BOTH = re.compile(rf"^{_NUM} <= .+ <= {_NUM} (.+)$")
_ONE = re.compile(rf"^.+ (<=|>=) {_NUM} (.+)$")


def verdict_summary(conformance: Mapping[str, object] | None) -> str:
    """``fail: worst B_z = 21 mg, limit |B_z| <= 5 mg (3 of 4 limits fail)``, or ``pass ...``.

    Parameters
    ----------
    conformance : mapping or None
        The envelope's ``conformance`` block
        (:meth:`inertest.quality.conformance.Conformance.to_dict`);
        None gives ``"- (no specification)"``.
    """
    if not conformance:
        return "- (no specification)"
    overall = str(conformance.get("overall"))
    found = conformance.get("verdicts")
    verdicts = [v for v in found if isinstance(v, Mapping)] if isinstance(found, list) else []
    n = len(verdicts)
    if overall == "pass":
        return f"pass ({n} of {n} limits)"
    worst = [v for v in verdicts if v.get("verdict") == overall]
    if not worst:
        return overall
    if overall == "not determined":
        names = ", ".join(str(v.get("quantity")) for v in worst)
        return f"not determined: {names} ({len(worst)} of {n} limits not determined by the test)"
    w = max(worst, key=_excess)  # the furthest outside (or least inside) its limit
    value = w.get("value")
    shown = f"{value:.3g}" if isinstance(value, float | int) else str(value)
    return (f"{overall}: worst {w.get('quantity')} = {shown} {w.get('unit')}, limit "
            f"{w.get('limit')} ({len(worst)} of {n} limits {overall})")


def _excess(v: Mapping[str, object]) -> float:
    """How far ``v``'s value lies beyond its first limit, in tolerances (larger is worse).

    ``|x| / max_abs``, ``|x - mid| / half-width``, or ``1 + (bound - x) / |bound|`` beyond a
    one-sided bound, with ``x`` in the limit's unit; -inf when the limit cannot be read.
    """
    text = str(v.get("limit", "")).split(", ")[0]
    value, unit = v.get("value"), str(v.get("unit"))
    if not isinstance(value, float | int):
        return -float("inf")
    try:
        if m := _MAX_ABS.match(text):
            tol, lim_unit = float(m[1]), m[2]
            return abs(convert(value, unit, lim_unit)) / tol if tol > 0 else float("inf")
        if m := _BOTH.match(text):
            lo, hi, lim_unit = float(m[1]), float(m[2]), m[3]
            x = convert(value, unit, lim_unit)
            return abs(x - 0.5 * (lo + hi)) / (0.5 * (hi - lo)) if hi > lo else float("inf")
        if m := _ONE.match(text):
            bound, lim_unit = float(m[2]), m[3]
            x = convert(value, unit, lim_unit)
            beyond = bound - x if m[1] == ">=" else x - bound
            return 1.0 + beyond / abs(bound) if bound else beyond
    except (UnitError, ValueError, ZeroDivisionError):
        pass
    return -float("inf")
