"""Report sections for any result, dispatched through the one procedure registry.

A procedure with figures of its own names its section builder in
:data:`inertest.procedures.REGISTRY`; any other result (every analysis kind, or a procedure
without one) gets the generic sections built from its JSON envelope.
"""

from __future__ import annotations

import importlib
import json
from collections.abc import Callable, Mapping
from typing import Any

from inertest.procedures import REGISTRY
from inertest.report.html import Section, paragraph, preformatted, table_html
from inertest.report.identification import fmt, identification_section

SectionBuilder = Callable[..., list[Section]]


def _builder(kind: str) -> SectionBuilder | None:
    info = REGISTRY.get(kind)
    if info is None or info.report is None:
        return None
    module, _, name = info.report.partition(":")
    builder: Callable[..., list[Section]] = getattr(importlib.import_module(module), name)
    return builder


def result_sections(
    result: Any, truth: Mapping[str, float] | None = None, *, title: str
) -> list[Section]:
    """Sections for ``result`` (with truth-vs-estimate columns when ``truth`` is given)."""
    kind = str(getattr(result, "kind", None) or getattr(result, "procedure", ""))
    builder = _builder(kind)
    if builder is not None:
        return builder(result, truth, title=title)
    if hasattr(result, "identification"):
        return [identification_section(title, result.identification, truth)]
    return envelope_sections(result.to_dict(), title=title)


def envelope_sections(doc: Mapping[str, Any], *, title: str) -> list[Section]:
    """Generic sections of any result envelope: identification, checks, messages, own block."""
    sec = Section(f"{title} ({doc.get('kind')})", [])
    ident = doc.get("identification") or {}
    rows = [[k, fmt(float(e["value"]), float(e["std"])), e["unit"]]
            for k, e in (ident.get("coefficients") or {}).items()]
    rows += [[c["name"], fmt(float(c["value"]), float(c["std"])), c["unit"]]
             for c in ident.get("combinations") or []]
    if rows:
        sec.parts.append(table_html(["quantity", "estimate ± std", "unit"], rows))
    for s in ident.get("not_separable") or []:
        sec.parts.append(paragraph("Not determined: " + str(s), note=True))
    checks = doc.get("checks") or []
    if checks:
        sec.parts.append(table_html(
            ["check", "verdict", "detail"],
            [[str(c.get("name", "")), str(c.get("verdict", "")),
              ", ".join(f"{k}={v}" for k, v in c.items() if k not in ("name", "verdict"))]
             for c in checks]))
    for m in doc.get("messages") or []:
        sec.parts.append(paragraph(str(m), note=True))
    body = doc.get("result") or {}
    if body:
        text = json.dumps(body, indent=1, allow_nan=True)
        if len(text) > 20000:
            text = text[:20000] + "\n... (truncated; the full result is in the JSON output)"
        sec.parts.append(preformatted(text))
    return [sec]
