"""Report sections for any procedure's result, dispatched on ``result.procedure``.

A procedure with figures of its own registers its section builder in :data:`SECTION_BUILDERS`;
others get the generic table of what the data determine.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from inertest.report import accelerometer, centrifuge, ferraris, gyro_triad, tumble
from inertest.report.html import Section
from inertest.report.identification import identification_section

SectionBuilder = Callable[..., list[Section]]

SECTION_BUILDERS: dict[str, SectionBuilder] = {
    "polar-tumble": tumble.polar_tumble_sections,
    "local-level-tumble": tumble.local_level_sections,
    "gyro-rate-table": gyro_triad.rate_table_sections,
    "gyro-triad-rotation": gyro_triad.rotation_sections,
    "ferraris": ferraris.ferraris_sections,
    "accelerometer-multipoint": accelerometer.multipoint_sections,
    "triad-multiposition": accelerometer.triad_sections,
    "centrifuge-nine-position": centrifuge.nine_position_sections,
}


def result_sections(
    result: Any, truth: Mapping[str, float] | None = None, *, title: str
) -> list[Section]:
    """Sections for ``result`` (with truth-vs-estimate columns when ``truth`` is given)."""
    builder = SECTION_BUILDERS.get(result.procedure)
    if builder is not None:
        return builder(result, truth, title=title)
    return [identification_section(title, result.identification, truth)]
