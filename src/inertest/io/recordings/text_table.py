"""Plain text tables: columns separated by spaces or tabs (``.txt``, ``.dat``, ``.log``, ...).

Lines starting with ``#`` or ``%`` are comments. The first other line is a header when any of
its fields is not a number (with tabs in it, fields are split at tabs only, so a name may hold
spaces: ``acc_x [m/s^2]``); without a header the columns are named ``column_1``,
``column_2``, ... Every row must have as many numbers as the first. Also what tells such a
table from the PSINS text format (:func:`looks_like_psins`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from inertest.errors import DataError

TEXT_SUFFIXES = (".txt", ".dat", ".log", ".tsv", ".asc")
_COMMENT = ("#", "%")


def _number(tok: str) -> bool:
    try:
        float(tok)
    except ValueError:
        return False
    return True


def looks_like_psins(lines: list[str]) -> bool:
    """Whether the first lines of a text file are the PSINS IMU format.

    PSINS (Yan Gongmin's toolbox): ``%`` comments, three parameter lines of 6 numbers (the
    third, the LSBs, positive), then rows of 6 integer increments and an optional time. A plain
    table of 6 or 7 real-valued columns is not PSINS.
    """
    body = [ln.split() for ln in lines if ln.strip() and not ln.lstrip().startswith(_COMMENT)]
    if len(body) < 4:
        return bool(lines) and lines[0].startswith("%") and len(body) == 0
    params, rows = body[:3], body[3:]
    if any(len(p) != 6 or not all(_number(t) for t in p) for p in params):
        return False
    if not all(float(t) > 0 for t in params[2]):
        return False
    for r in rows[:-1]:  # the last line read may be cut
        if len(r) not in (6, 7) or not all(_number(t) for t in r):
            return False
        if not all(float(t).is_integer() for t in r[:6]):
            return False
    return True


def read_text_table(path: Path, lines: list[str]) -> dict[str, NDArray]:
    """Columns of a whitespace / tab separated text table (``lines``: the file's lines).

    Numbers become float64; errors name the first row that does not parse.
    """
    body = [(k, ln) for k, ln in enumerate(lines, start=1)
            if ln.strip() and not ln.lstrip().startswith(_COMMENT)]
    if not body:
        raise DataError(f"{path} has no rows (only comments or blank lines); give a recording "
                        "with samples")
    first = body[0][1].rstrip("\r\n")
    tabs = "\t" in first
    fields = [f.strip() for f in first.split("\t")] if tabs else first.split()
    if not all(_number(f) for f in fields if f):
        names = fields
        rows = body[1:]
        if len(set(names)) != len(names):
            dup = next(n for n in names if names.count(n) > 1)
            raise DataError(f"{path}: the header names the column {dup!r} twice; give each "
                            "column its own name")
    else:
        names = [f"column_{i + 1}" for i in range(len(fields))]
        rows = body
    if not rows:
        raise DataError(f"{path} has a header ({' '.join(names)}) but no rows of samples")
    width = len(names)
    try:
        data = np.loadtxt([ln for _, ln in rows], ndmin=2, delimiter="\t" if tabs else None,
                          dtype=np.float64, comments=None)
    except ValueError:
        raise DataError(f"{path}: {_bad_row(rows, width, tabs)}; every row holds {width} "
                        "numbers separated by spaces or tabs") from None
    if data.shape[1] != width:
        raise DataError(f"{path}: the rows have {data.shape[1]} numbers and the header names "
                        f"{width} columns ({' '.join(names)})")
    return {n: np.ascontiguousarray(data[:, j]) for j, n in enumerate(names)}


def _bad_row(rows: list[tuple[int, str]], width: int, tabs: bool) -> str:
    for k, ln in rows:
        toks = [t.strip() for t in ln.split("\t")] if tabs else ln.split()
        for tok in toks:
            if not _number(tok):
                return f"line {k} holds {tok[:20]!r}, which is not a number"
        if len(toks) != width:
            last = " (the last line: the file is cut off)" if k == rows[-1][0] else ""
            return f"line {k} has {len(toks)} numbers, not {width}{last}"
    return "the rows cannot be read as numbers"

