"""PDF export of an HTML report with a headless Chromium (optional; Debian package chromium).

Chromium runs with its sandbox (except as root, where it cannot), JavaScript disabled, and a
throw-away profile.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

from inertest.errors import InertestError

_CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "chrome")


def find_chromium() -> str | None:
    """Path of a Chromium-family browser: ``$INERTEST_CHROMIUM`` or one on PATH."""
    env = os.environ.get("INERTEST_CHROMIUM")
    if env:
        return env if Path(env).exists() else None
    for name in _CANDIDATES:
        path = shutil.which(name)
        if path:
            return path
    return None


#: Content Security Policy of the page Chromium prints: no scripts, no network, no frames.
CSP = ("default-src 'none'; img-src data:; style-src 'unsafe-inline'; font-src data:; "
       "script-src 'none'; frame-src 'none'")


def _locked_down(html: str) -> str:
    """``html`` with a Content-Security-Policy meta element first in its head."""
    meta = f'<meta http-equiv="Content-Security-Policy" content="{CSP}">'
    head = re.search(r"<head[^>]*>", html, flags=re.IGNORECASE)
    if head is None:
        return meta + html
    return html[:head.end()] + meta + html[head.end():]


def html_to_pdf(html_path: Path, pdf_path: Path, *, timeout_s: float = 120.0) -> Path:
    """Print ``html_path`` to ``pdf_path`` with headless Chromium (the page's print CSS)."""
    browser = find_chromium()
    if browser is None:
        raise InertestError(
            "PDF export needs Chromium: install it (Debian: apt-get install chromium) or set "
            "INERTEST_CHROMIUM to the browser's path; the HTML report needs nothing"
        )
    # The report is self-contained and has no scripts: Chromium prints a copy whose Content
    # Security Policy forbids scripts and every fetch (only inline styles and data: images), and
    # keeps its sandbox unless it runs as root (where Chromium refuses to start with it).
    # (--blink-settings=scriptEnabled=false would be simpler, but then no PDF is printed.)
    as_root = hasattr(os, "geteuid") and os.geteuid() == 0
    with tempfile.TemporaryDirectory(prefix="inertest-chromium-") as profile:
        page = Path(profile) / "report.html"
        page.write_text(_locked_down(Path(html_path).read_text(encoding="utf-8")),
                        encoding="utf-8")
        cmd = [
            browser, "--headless", *(["--no-sandbox"] if as_root else []), "--disable-gpu",
            "--no-first-run", "--disable-extensions",
            "--disable-background-networking", "--disable-component-update", "--disable-sync",
            f"--user-data-dir={profile}", "--no-pdf-header-footer",
            f"--print-to-pdf={pdf_path}", page.resolve().as_uri(),
        ]
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s,
                                  check=False)
        except subprocess.TimeoutExpired:
            raise InertestError(
                f"Chromium did not finish printing the PDF in {timeout_s:g} s"
            ) from None
        except OSError as exc:
            raise InertestError(f"cannot start Chromium {browser}: {exc.strerror or exc}; set "
                                "INERTEST_CHROMIUM to a working browser") from None
    if proc.returncode != 0 or not Path(pdf_path).exists():
        tail = (proc.stderr or "").strip().splitlines()[-1:] or ["no message"]
        raise InertestError(f"Chromium could not print the PDF: {tail[0]}")
    return Path(pdf_path)
