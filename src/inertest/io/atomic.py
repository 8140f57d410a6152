"""Atomic writes, so that a failed command leaves nothing half-written.

Files and report folders are written under a hidden temporary name beside their target and
renamed into place at the end; every exit path that Python sees (errors, Ctrl-C, SIGTERM through
the command line) removes the temporary. A process killed outright (SIGKILL, power loss) leaves
its hidden temporary behind: the temporary's name carries the host and process id, and the next
write to the same target removes those whose process is gone.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import socket
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from inertest.errors import OutputPathError


def write_text(path: str | os.PathLike[str], text: str) -> Path:
    """Write ``text`` to ``path`` through a temporary file in the same folder and a rename."""
    with target_file(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _host() -> str:
    return re.sub(r"[^A-Za-z0-9_-]", "_", socket.gethostname())[:40] or "host"


def _temp_prefix(final: Path) -> str:
    """Hidden name prefix of this process's temporaries for ``final``."""
    return f".{final.name}.inertest-tmp-{_host()}-{os.getpid()}-"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's live process
        return True
    return True


def remove_stale_temporaries(final: str | os.PathLike[str]) -> list[Path]:
    """Remove temporaries left beside ``final`` by killed inertest processes on this host.

    Any inertest temporary in the folder counts (not only ``final``'s): a report killed
    half-way is not necessarily written again under the same name.
    """
    target = Path(final)
    pattern = re.compile(r"^\..+\.inertest-tmp-" + re.escape(_host()) + r"-(\d+)-")
    removed = []
    try:
        siblings = list(target.parent.iterdir())
    except OSError:
        return removed
    for sib in siblings:
        m = pattern.match(sib.name)
        if m is None or _alive(int(m.group(1))):
            continue
        if sib.is_dir() and not sib.is_symlink():
            shutil.rmtree(sib, ignore_errors=True)
        else:
            sib.unlink(missing_ok=True)
        removed.append(sib)
    return removed


@contextlib.contextmanager
def target_file(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` if the block succeeds."""
    final = Path(path)
    final.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(final)
    fd, name = tempfile.mkstemp(prefix=_temp_prefix(final), suffix=".tmp", dir=final.parent)
    os.close(fd)
    tmp = Path(name)
    os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; a written file follows the umask
    try:
        yield tmp
        os.replace(tmp, final)
    finally:
        tmp.unlink(missing_ok=True)


#: Manifest of a report folder written by inertest: JSON ``{"written_by": "inertest", "files":
#: [...]}``. Only the files it lists are ever replaced or removed; anything else in the folder is
#: the user's and is left alone.
REPORT_MARKER = ".inertest-report"


def check_outputs(outputs: Iterable[str | os.PathLike[str]],
                  inputs: Iterable[str | os.PathLike[str]]) -> None:
    """Refuse an output that is an input, or a folder that holds an input (also via symlinks).

    Called before any work starts, so that a mistyped output never overwrites the user's data.
    """
    ins = [Path(i).resolve() for i in inputs]
    for o in outputs:
        out = Path(o).resolve()
        for i in ins:
            if out == i or out in i.parents:
                raise OutputPathError(
                    f"output {o} would overwrite the input {i}; choose another output path")


def report_manifest(folder: str | os.PathLike[str]) -> list[str] | None:
    """Files an earlier inertest report in ``folder`` wrote, or None when it has no manifest."""
    marker = Path(folder) / REPORT_MARKER
    try:
        doc = json.loads(marker.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(doc, dict) or doc.get("written_by") != "inertest":
        return None
    files = doc.get("files")
    if not isinstance(files, list) or not all(isinstance(f, str) for f in files):
        return None
    return [f for f in files if f and not Path(f).is_absolute() and ".." not in Path(f).parts]


def check_report_directory(path: str | os.PathLike[str]) -> None:
    """Refuse a report folder that exists, is not empty and holds no inertest report."""
    final = Path(path)
    if final.name in ("", ".", ".."):
        raise OutputPathError(
            f"report folder {str(path)!r} has no name of its own; give a new folder such as "
            "./report")
    if final.exists() and not final.is_dir():
        raise OutputPathError(f"report folder {final} is an existing file; give a folder name")
    if final.is_dir() and any(final.iterdir()) and report_manifest(final) is None:
        raise OutputPathError(
            f"report folder {final} already holds files that inertest did not write (no "
            f"inertest {REPORT_MARKER} manifest); give a new folder, or an earlier inertest "
            "report folder")


@contextlib.contextmanager
def target_directory(
    path: str | os.PathLike[str], *, inputs: Iterable[str | os.PathLike[str]] = ()
) -> Iterator[Path]:
    """Yield a temporary directory beside ``path``; its files go into ``path`` if the block works.

    ``path`` may be a new folder, an empty one, or an earlier inertest report (its
    :data:`REPORT_MARKER` manifest lists what inertest wrote); never one holding an input or
    other files without a manifest: those raise :class:`~inertest.errors.OutputPathError`
    before the block runs. Into an earlier report, the new files replace the old ones and the
    old report's files that the new one does not write are removed; files the manifest does not
    list (the user's notes, a history database kept there) are never touched.
    """
    final = Path(path)
    check_report_directory(final)
    check_outputs([final], inputs)
    final.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(final)
    tmp = Path(tempfile.mkdtemp(prefix=_temp_prefix(final), dir=final.parent))
    os.chmod(tmp, 0o777 & ~_umask())
    try:
        yield tmp
        written = sorted(str(f.relative_to(tmp)) for f in tmp.rglob("*")
                         if f.is_file() and f.name != REPORT_MARKER)
        (tmp / REPORT_MARKER).write_text(json.dumps(
            {"written_by": "inertest", "note": "inertest may replace the files listed here "
             "with a newer report; it never touches other files in this folder",
             "files": written}, indent=1), encoding="utf-8")
        for f in tmp.rglob("*"):
            os.chmod(f, (0o777 if f.is_dir() else 0o666) & ~_umask())
        if not final.exists():
            os.replace(tmp, final)
            return
        check_report_directory(final)  # still a report of ours, also if it changed meanwhile
        old = report_manifest(final) or []
        for rel in written:
            dest = final / rel
            dest.parent.mkdir(parents=True, exist_ok=True)
            os.replace(tmp / rel, dest)
        for rel in sorted(set(old) - set(written)):
            stale = final / rel
            if stale.is_file() and not stale.is_symlink():
                stale.unlink()
        # The manifest last: until it is in place the folder still describes the old report.
        os.replace(tmp / REPORT_MARKER, final / REPORT_MARKER)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
