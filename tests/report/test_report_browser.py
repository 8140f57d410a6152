"""Every report kind in a real headless browser (Debian's Chromium driven by Playwright).

References nobody here wrote: Chromium's layout (no horizontal overflow at a 1200 px viewport,
no console errors, every table and figure rendered), Chromium's own print to PDF, and poppler's
``pdfinfo`` (page size in points: ISO 216 A4 is 210 x 297 mm = 595 x 842 pt) and ``pdftoppm``
(each page rendered, none blank).
"""

import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from inertest.cli import main

ARTIFACTS = Path(__file__).resolve().parents[2] / "build" / "test-artifacts"

VIEWPORT_PX = 1200
A4_PT = (595, 842)


def _missing(what: str) -> None:
    """Skip on a workstation without ``what``; fail in CI, where .ci/services installs it."""
    if os.environ.get("CI") == "true":
        pytest.fail(f"CI without {what}: .ci/services should have installed it")
    pytest.skip(f"no {what}")


def _chromium() -> str:
    path = os.environ.get("INERTEST_CHROMIUM") or shutil.which("chromium")
    if not path:
        _missing("Chromium: apt-get install chromium (.ci/services installs it)")
    return path


def _pdf_pages(pdf: Path) -> list[tuple[float, float]]:
    info = subprocess.run(["pdfinfo", "-f", "1", "-l", "999", str(pdf)], capture_output=True,
                          text=True, check=True).stdout
    return [(float(w), float(h)) for w, h in
            re.findall(r"Page\s+\d+ size:\s+([\d.]+) x ([\d.]+) pts", info)]


def _blank_pages(pdf: Path, folder: Path) -> list[int]:
    """Pages that pdftoppm renders with nothing darker than light grey (1-based)."""
    subprocess.run(["pdftoppm", "-gray", "-r", "24", str(pdf), str(folder / "p")], check=True)
    blank = []
    for k, f in enumerate(sorted(folder.glob("p-*.pgm"), key=lambda p: int(p.stem[2:])), 1):
        raw = f.read_bytes()
        # binary PGM: "P5\n<w> <h>\n<max>\n" then w*h bytes
        header = re.match(rb"P5\s+(\d+)\s+(\d+)\s+(\d+)\s", raw)
        w, h = int(header.group(1)), int(header.group(2))
        pixels = np.frombuffer(raw[header.end():header.end() + w * h], dtype=np.uint8)
        if not (pixels < 200).any():
            blank.append(k)
    return blank


@pytest.mark.slow
def test_every_report_kind_fits_1200px_renders_and_prints_on_a4(reports, tmp_path):
    try:
        from playwright import sync_api
    except ImportError:
        _missing("playwright (pip install playwright; a dependency of inertest)")
    exe = _chromium()
    if not (shutil.which("pdfinfo") and shutil.which("pdftoppm")):
        _missing("poppler-utils: apt-get install poppler-utils (.ci/services installs it)")
    from inertest.report.pdf import html_to_pdf

    found = {}
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(
            executable_path=exe,
            args=["--no-sandbox", "--disable-gpu", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--no-first-run"])
        page = browser.new_page(viewport={"width": VIEWPORT_PX, "height": 900})
        errors: list[str] = []
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda e: errors.append(str(e)))
        ARTIFACTS.mkdir(parents=True, exist_ok=True)
        for name, html in reports.items():
            errors.clear()
            page.goto(html.as_uri())
            source = html.read_text(encoding="utf-8")
            found[name] = {
                "errors": list(errors),
                "scroll_width": page.evaluate("document.documentElement.scrollWidth"),
                "tables_in_source": source.count("<table"),
                "tables": page.eval_on_selector_all(
                    "table", "els => els.filter(e => e.getBoundingClientRect().width > 0)"
                    ".length"),
                "figures_in_source": source.count("<img"),
                "figures": page.eval_on_selector_all(
                    "img", "els => els.filter(e => e.complete && e.naturalWidth > 100 && "
                    "e.getBoundingClientRect().width > 100).length"),
            }
            page.screenshot(path=str(ARTIFACTS / f"report-{name.replace(' ', '-')}.png"),
                            full_page=True)
        browser.close()
    for name, f in found.items():
        assert f["errors"] == [], name
        assert f["scroll_width"] <= VIEWPORT_PX, (name, f["scroll_width"])
        assert f["tables"] == f["tables_in_source"] >= 2, (name, f)
        assert f["figures"] == f["figures_in_source"], (name, f)
    # figures a user expects in each kind (at least)
    for name in ("demo", "allan", "modulation", "ins-errors", "history", "fit polar-tumble"):
        assert found[name]["figures"] >= 1, name
    assert found["history"]["figures"] > found["fit polar-tumble"]["figures"]

    # One PDF per report kind (the per-fit pages share one layout: the widest tables of them,
    # the accelerometer's Fourier terms, stand for all), which keeps the test near 3 minutes.
    printed = {n: h for n, h in reports.items()
               if not n.startswith("fit ") or n == "fit accelerometer-multipoint"}
    for name, html in printed.items():
        pdf = tmp_path / "pdf" / f"{name.replace(' ', '-')}.pdf"
        pdf.parent.mkdir(exist_ok=True)
        html_to_pdf(html, pdf)
        pages = _pdf_pages(pdf)
        assert pages, name
        assert all((round(w), round(h)) == A4_PT for w, h in pages), (name, pages)
        folder = tmp_path / "pdf" / pdf.stem
        folder.mkdir()
        assert _blank_pages(pdf, folder) == [], name


@pytest.mark.slow
def test_pdf_export_from_the_command_line(tmp_path, examples_dir):
    _chromium()
    plan = examples_dir / "polar_tumble" / "plan.toml"
    data = tmp_path / "d.csv"
    main(["simulate", str(plan), "--truth", str(examples_dir / "polar_tumble" / "truth.toml"),
          "-o", str(data), "--noise", "0.002"])
    assert main(["fit", str(plan), str(data), "--no-store", "--report", str(tmp_path / "r"),
                 "--pdf"]) == 0
    assert (tmp_path / "r" / "report.pdf").read_bytes()[:5] == b"%PDF-"
