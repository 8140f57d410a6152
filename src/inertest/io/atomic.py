"""Atomic writes, so that a failed command leaves nothing half-written.

Files and report folders are written under a hidden temporary name beside their target and
renamed into place at the end; every exit path that Python sees (errors, Ctrl-C, SIGTERM through
the command line) removes the temporary. A process killed outright (SIGKILL, power loss) leaves
its hidden temporary behind: the temporary's name carries the host and process id, and the next
write to the same target removes those whose process is gone. An error while writing names the
user's path, never the hidden temporary.

Every path written or removed inside a folder goes through :func:`path_inside`: it must lie
inside the folder through real folders only, never behind a symbolic link.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import shutil
import socket
import tempfile
import warnings
from collections.abc import Iterable, Iterator
from pathlib import Path

from inertest.errors import TEMP_MARK, InertestWarning, OutputPathError


def path_inside(folder: str | os.PathLike[str], rel: str | os.PathLike[str], *,
                what: str | None = None) -> Path:
    """``folder / rel``, refused unless it lies inside ``folder`` through real folders only.

    ``rel`` must be relative, without ``..``; no component from ``folder`` down to the path
    itself may be a symbolic link (a link could lead anywhere, and ``unlink`` or
    ``os.replace`` would then act outside the folder); the resolved path must lie under the
    resolved ``folder``. ``folder`` itself may be a link: it is the path the user gave.

    Raises
    ------
    OutputPathError
        Naming the path, the link and the fix; ``what`` starts the message (default
        ``"folder FOLDER: the path"``).
    """
    base = Path(folder)
    relative = Path(rel)
    head = what if what is not None else f"folder {base}: the path"
    if (relative.is_absolute() or not relative.parts or ".." in relative.parts
            or relative.drive):
        raise OutputPathError(
            f"{head} {str(rel)!r}, which is not a path inside the folder; inertest writes and "
            "removes files only inside it: correct the path, or give a new folder")
    current = base
    for part in relative.parts:
        current = current / part
        if current.is_symlink():
            raise OutputPathError(
                f"{head} {relative}, which lies behind the symbolic link {current} (to "
                f"{os.readlink(current)}); inertest writes and removes files only through "
                "real folders: remove the link, or give a new folder")
        if not current.exists():
            break
    target = base / relative
    if not target.resolve().is_relative_to(base.resolve()):
        raise OutputPathError(
            f"{head} {relative}, which resolves outside the folder; remove the links on the "
            "way, or give a new folder")
    return target


def _user_path_error(exc: OSError, tmp: Path | None, final: Path) -> OSError:
    """``exc`` naming ``final`` (or a file in it) where it named the hidden temporary ``tmp``.

    ``tmp`` is None when the temporary could not even be created: any name of this process's
    temporaries beside ``final`` then stands for ``final``. A full disk that a writer reports
    without a file name (Arrow, HDF5) is named at ``final``.
    """
    code = exc.errno  # an int when it is one of the two (``in`` does not narrow for mypy)
    if exc.filename is None and code is not None and code in (errno.ENOSPC,
                                                              getattr(errno, "EDQUOT", -1)):
        return type(exc)(code, exc.strerror or os.strerror(code), str(final))

    def user(name: object) -> object:
        if not isinstance(name, str | bytes):
            return name
        p = Path(os.fsdecode(name))
        if tmp is not None and p.is_relative_to(tmp):
            return str(final / p.relative_to(tmp)) if p != tmp else str(final)
        if p.parent == final.parent and p.name.startswith(_temp_prefix(final)):
            return str(final)
        return name

    new, new2 = user(exc.filename), user(exc.filename2)
    if new is exc.filename and new2 is exc.filename2:
        return exc
    if exc.errno is None:
        return exc
    return type(exc)(exc.errno, exc.strerror, new, None, new2)


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
    return f".{final.name}{TEMP_MARK}{_host()}-{os.getpid()}-"


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
    pattern = re.compile(r"^\..+" + re.escape(TEMP_MARK) + re.escape(_host()) + r"-(\d+)-")
    removed: list[Path] = []
    try:
        siblings = list(target.parent.iterdir())
    except OSError:
        return removed
    for sib in siblings:
        m = pattern.match(sib.name)
        if m is None or sib.is_symlink() or _alive(int(m.group(1))):
            continue  # inertest never makes a temporary that is a link: not ours
        if sib.is_dir():
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
    tmp: Path | None = None
    try:
        fd, name = tempfile.mkstemp(prefix=_temp_prefix(final), suffix=".tmp", dir=final.parent)
        os.close(fd)
        tmp = Path(name)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; a written file follows the umask
        yield tmp
        os.replace(tmp, final)
    except OSError as exc:
        raise _user_path_error(exc, tmp, final) from None
    finally:
        if tmp is not None:
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
    """Files an earlier inertest report in ``folder`` wrote, or None when it has no manifest.

    A marker that is not inertest's (no ``"written_by": "inertest"``, not JSON) is no manifest.
    One of inertest's that lists anything but paths inside the folder through real folders
    (:func:`path_inside`), or that is itself a symbolic link, is refused: inertest would remove
    those files.

    Raises
    ------
    OutputPathError
        Naming the manifest, the entry and the fix.
    """
    base = Path(folder)
    marker = base / REPORT_MARKER
    if marker.is_symlink():
        raise OutputPathError(
            f"report folder {base}: its manifest {REPORT_MARKER} is a symbolic link (to "
            f"{os.readlink(marker)}), not the file inertest wrote; remove it, or give a new "
            "folder")
    try:
        doc = json.loads(marker.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(doc, dict) or doc.get("written_by") != "inertest":
        return None
    files = doc.get("files")
    if not isinstance(files, list) or not all(isinstance(f, str) and f for f in files):
        raise OutputPathError(
            f"report folder {base}: its manifest {REPORT_MARKER} is damaged (\"files\" must be "
            "a list of file names); delete the manifest and the report's files, or give a new "
            "folder")
    for f in files:
        path_inside(base, f, what=f"report folder {base}: its manifest {REPORT_MARKER} lists")
    return list(files)


def check_report_directory(path: str | os.PathLike[str]) -> None:
    """Refuse a report folder that exists, is not empty and holds no inertest report.

    Also one whose manifest lists a path outside the folder or behind a symbolic link
    (:func:`report_manifest`).
    """
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
    list (the user's notes, a history database kept there) are never touched. Every file
    written or removed lies inside ``path`` through real folders (:func:`path_inside`); any
    that would not is refused before anything is replaced.
    """
    final = Path(path)
    check_report_directory(final)
    check_outputs([final], inputs)
    final.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(final)
    tmp: Path | None = None
    try:
        tmp = Path(tempfile.mkdtemp(prefix=_temp_prefix(final), dir=final.parent))
        os.chmod(tmp, 0o777 & ~_umask())
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
        # Every path checked before the first is replaced: nothing is written half-way.
        for rel in [*written, REPORT_MARKER]:
            _check_replaceable(final, rel)
        for rel in written:
            dest = final / rel
            dest.parent.mkdir(parents=True, exist_ok=True)
            os.replace(tmp / rel, path_inside(
                final, rel, what=f"report folder {final}: the report writes"))
        for rel in sorted(set(old) - set(written)):
            _remove_stale_file(final, rel)
        # The manifest last: until it is in place the folder still describes the old report.
        os.replace(tmp / REPORT_MARKER, final / REPORT_MARKER)
    except OSError as exc:
        raise _user_path_error(exc, tmp, final) from None
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)


def _check_replaceable(folder: Path, rel: str) -> None:
    """Refuse a report file ``rel`` that cannot replace what ``folder`` holds at its path."""
    head = f"report folder {folder}: the report writes"
    dest = path_inside(folder, rel, what=head)
    clash = dest if dest.is_dir() else next(
        (p for p in dest.parents if p != folder and p.is_relative_to(folder) and p.exists()
         and not p.is_dir()), None)
    if clash is not None:
        kind = "folder" if clash == dest else "file"
        raise OutputPathError(f"{head} {rel}, but the folder holds a {kind} "
                              f"{clash.relative_to(folder)} there; move it away, or give a new "
                              "folder")


def _remove_stale_file(folder: Path, rel: str) -> None:
    """Remove an earlier report's file ``rel`` of ``folder``; one behind a link is left, warned."""
    try:
        stale = path_inside(folder, rel, what=f"report folder {folder}: the earlier "
                            "report's file")
    except OutputPathError as exc:  # the folder changed since it was checked
        warnings.warn(f"{exc}; it was left in place", InertestWarning, stacklevel=3)
        return
    if stale.is_file():
        stale.unlink()
