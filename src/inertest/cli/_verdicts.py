"""One-line overall verdict of a result's ``conformance`` block (``batch``, ``demo``)."""

from __future__ import annotations

from collections.abc import Mapping


def verdict_summary(conformance: Mapping[str, object] | None) -> str:
    """``fail: worst B_z = 21 mg, limit |B_z| <= 5 mg (3 of 4 limits fail)``, or ``pass ...``.

    Parameters
    ----------
    conformance : mapping or None
        The envelope's ``conformance`` block (:meth:`inertest.conformance.Conformance.to_dict`);
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
    w = worst[0]
    value = w.get("value")
    shown = f"{value:.3g}" if isinstance(value, float | int) else str(value)
    return (f"{overall}: worst {w.get('quantity')} = {shown} {w.get('unit')}, limit "
            f"{w.get('limit')} ({len(worst)} of {n} limits {overall})")
