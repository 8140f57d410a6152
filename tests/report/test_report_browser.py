"""The campaign report in a real headless browser (Debian's Chromium driven by Playwright)."""

import os
import shutil
from pathlib import Path

import pytest

from inertest.cli import main

ARTIFACTS = Path(__file__).resolve().parents[2] / "build" / "test-artifacts"


def _chromium() -> str:
    path = os.environ.get("INERTEST_CHROMIUM") or shutil.which("chromium")
    if not path:
        pytest.skip("no Chromium: apt-get install chromium (.ci/run installs it)")
    return path


@pytest.fixture
def report(tmp_path, examples_dir):
    plan = examples_dir / "polar_tumble" / "plan.toml"
    truth = examples_dir / "polar_tumble" / "truth.toml"
    db = tmp_path / "h.db"
    for i in range(2):
        data = tmp_path / f"d{i}.csv"
        main(["simulate", str(plan), "--truth", str(truth), "-o", str(data), "--noise", "0.002",
              "--seed", str(i)])
        main(["fit", str(plan), str(data), "--db", str(db), "--report", str(tmp_path / "rep"),
              "--tested-at", f"2026-0{i + 1}-01"])
    return tmp_path / "rep" / "index.html"


@pytest.mark.slow
def test_report_renders_without_console_errors(report):
    sync_api = pytest.importorskip("playwright.sync_api")
    exe = _chromium()
    errors = []
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(
            executable_path=exe,
            args=["--no-sandbox", "--disable-gpu", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--no-first-run"])
        page = browser.new_page(viewport={"width": 1280, "height": 900})
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(report.as_uri())
        images = page.eval_on_selector_all(
            "img", "els => els.map(e => [e.complete, e.naturalWidth])")
        n_tables = page.locator("table").count()
        title = page.title()
        ARTIFACTS.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(ARTIFACTS / "campaign-report.png"), full_page=True)
        browser.close()
    assert errors == []
    assert len(images) == 2 and all(c and w > 300 for c, w in images)
    assert n_tables >= 5
    assert "polar-tumble" in title


@pytest.mark.slow
def test_pdf_export(tmp_path, examples_dir):
    _chromium()
    plan = examples_dir / "polar_tumble" / "plan.toml"
    data = tmp_path / "d.csv"
    main(["simulate", str(plan), "--truth", str(examples_dir / "polar_tumble" / "truth.toml"),
          "-o", str(data), "--noise", "0.002"])
    assert main(["fit", str(plan), str(data), "--no-store", "--report", str(tmp_path / "r"),
                 "--pdf"]) == 0
    assert (tmp_path / "r" / "report.pdf").read_bytes()[:5] == b"%PDF-"
