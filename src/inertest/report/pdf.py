"""PDF export of an HTML report with a headless Chromium (optional; Debian package chromium)."""

from __future__ import annotations

import os
import shutil
import subprocess
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


def html_to_pdf(html_path: Path, pdf_path: Path, *, timeout_s: float = 120.0) -> Path:
    """Print ``html_path`` to ``pdf_path`` with headless Chromium (the page's print CSS)."""
    browser = find_chromium()
    if browser is None:
        raise InertestError(
            "PDF export needs Chromium: install it (Debian: apt-get install chromium) or set "
            "INERTEST_CHROMIUM to the browser's path; the HTML report needs nothing"
        )
    cmd = [
        browser, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync",
        "--no-pdf-header-footer", f"--print-to-pdf={pdf_path}",
        Path(html_path).resolve().as_uri(),
    ]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s, check=False)
    except subprocess.TimeoutExpired:
        raise InertestError(
            f"Chromium did not finish printing the PDF in {timeout_s:g} s"
        ) from None
    if proc.returncode != 0 or not Path(pdf_path).exists():
        tail = (proc.stderr or "").strip().splitlines()[-1:] or ["no message"]
        raise InertestError(f"Chromium could not print the PDF: {tail[0]}")
    return Path(pdf_path)
