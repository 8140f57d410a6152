"""Every report kind in a real headless browser and printed to A4: a certificate's layout.

References nobody here wrote: Chromium's layout (Debian's Chromium driven by Playwright),
Chromium's print to PDF, and poppler's ``pdfinfo`` (page size: ISO 216 A4 is 210 x 297 mm =
595 x 842 pt), ``pdftotext`` (the text of each printed page) and ``pdftoppm`` (each page
rendered, none blank). Each report kind is rendered once (one browser, one fixture); the tests
read what it measured.

What a quality manager signs (ISO/IEC 17025:2017 7.8.2.1): every printed page names the report
and the instrument and says "page k of n"; the last page says the report ends there; no table
hides a column behind a scroll bar or splits a number, at a 1200 px screen, on a phone and
on A4; headers break between words only.
"""

import os
import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

ARTIFACTS = Path(__file__).resolve().parents[2] / "build" / "test-artifacts"

VIEWPORT_PX = 1200
PHONE_PX = 420
#: A4's width less the report's 14 mm side margins, in CSS px (96 per inch).
A4_CONTENT_PX = round((210 - 2 * 14) / 25.4 * 96)
A4_PT = (595, 842)
#: The report kinds the issue names (each must pass every check).
KINDS = ("demo", "fit polar-tumble", "history", "allan", "noise", "centrifuge-study",
         "thermal triad", "ins-errors", "modulation", "history figure")

#: Elements wider than their box, and words (numbers, header words) split over lines.
_LAYOUT_JS = """() => {
  const wide = [];
  for (const el of document.querySelectorAll('body *')) {
    const cs = getComputedStyle(el);
    if (cs.display === 'inline' || cs.display.startsWith('table-') || el.clientWidth === 0)
      continue;
    if (el.scrollWidth > el.clientWidth + 1)
      wide.push(`${el.tagName}.${el.className} ${el.scrollWidth}>${el.clientWidth}: `
                + el.textContent.slice(0, 60));
  }
  const split = [];
  for (const cell of document.querySelectorAll('td, th, caption')) {
    if (cell.classList.contains('x')) continue;          // a hash or a path may break
    const walk = document.createTreeWalker(cell, NodeFilter.SHOW_TEXT);
    let node;
    while ((node = walk.nextNode())) {
      const re = /\\S+/g;
      let m;
      while ((m = re.exec(node.data))) {
        const r = document.createRange();
        r.setStart(node, m.index);
        r.setEnd(node, m.index + m[0].length);
        const tops = new Set(Array.from(r.getClientRects()).filter(x => x.width > 0)
                             .map(x => Math.round(x.top)));
        if (tops.size < 2) continue;
        // in a cell a number (any word with a digit) never breaks, other words may wrap;
        // in a header or caption a word breaks only after its own hyphen or slash
        if (cell.tagName === 'TD') {
          if (/\\d/.test(m[0]) && !m[0].includes('/')) split.push(m[0]);  // a path may break
          continue;
        }
        for (let i = 1; i < m[0].length; i++) {
          const a = document.createRange(), b = document.createRange();
          a.setStart(node, m.index + i - 1); a.setEnd(node, m.index + i);
          b.setStart(node, m.index + i); b.setEnd(node, m.index + i + 1);
          const ta = a.getClientRects()[0], tb = b.getClientRects()[0];
          if (ta && tb && Math.round(tb.top) > Math.round(ta.top) && !'-/'.includes(m[0][i - 1]))
            split.push(m[0]);
        }
      }
    }
  }
  const tables = Array.from(document.querySelectorAll('table'))
    .filter(e => e.getBoundingClientRect().width > 0).length;
  const figures = Array.from(document.querySelectorAll('img'))
    .filter(e => e.complete && e.naturalWidth > 100 && e.getBoundingClientRect().width > 100)
    .length;
  return {wide, split, tables, figures};
}"""


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


def _poppler() -> None:
    if not all(shutil.which(t) for t in ("pdfinfo", "pdftoppm", "pdftotext")):
        _missing("poppler-utils: apt-get install poppler-utils (.ci/services installs it)")


def _pdf_pages(pdf: Path) -> list[tuple[float, float]]:
    info = subprocess.run(["pdfinfo", "-f", "1", "-l", "999", str(pdf)], capture_output=True,
                          text=True, check=True).stdout
    return [(float(w), float(h)) for w, h in
            re.findall(r"Page\s+\d+ size:\s+([\d.]+) x ([\d.]+) pts", info)]


def _page_texts(pdf: Path, n: int) -> list[str]:
    return [subprocess.run(["pdftotext", "-f", str(k), "-l", str(k), str(pdf), "-"],
                           capture_output=True, text=True, check=True).stdout
            for k in range(1, n + 1)]


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


#: A number as printed: optional sign, digits with a decimal point, optional exponent.
_NUMBER = re.compile(r"(?<![\w.])[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?(?![\w.])")


class _CellNumbers(HTMLParser):
    """The numbers printed in the table cells of a report (hashes and paths left out)."""

    def __init__(self):
        super().__init__()
        self.depth = 0
        self.skip = 0
        self.numbers: set[str] = set()

    def handle_starttag(self, tag, attrs):
        if tag in ("td", "th"):
            self.depth += 1
            self.skip += "x" in (dict(attrs).get("class") or "").split()

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self.depth:
            self.depth -= 1
            self.skip = 0

    def handle_data(self, data):
        if self.depth and not self.skip:
            for word in data.replace("\u00a0", " ").split():
                if "/" not in word:  # a path is no number
                    self.numbers.update(m.group() for m in _NUMBER.finditer(word))


def _report_id(html: str) -> str:
    return re.search(r'<p class="end">End of report (\S+?)[ :]', html).group(1)


@pytest.fixture(scope="session")  # once a worker, whatever runs in between
def rendered(reports, tmp_path_factory):
    """Each report kind measured once: at 1200 px, on a phone, in A4 print, and as an A4 PDF."""
    try:
        from playwright import sync_api
    except ImportError:
        _missing("playwright (pip install playwright; a test dependency of inertest)")
    exe = _chromium()
    _poppler()
    out = {}
    pdfs = tmp_path_factory.mktemp("pdf")
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(
            executable_path=exe,
            args=["--no-sandbox", "--disable-gpu", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--no-first-run"])
        page = browser.new_page(viewport={"width": VIEWPORT_PX, "height": 900})
        errors: list[str] = []
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda e: errors.append(str(e)))
        for name, html in reports.items():
            errors.clear()
            source = html.read_text(encoding="utf-8")
            f = {"source": source, "id": _report_id(source)}
            page.emulate_media(media="screen")
            page.set_viewport_size({"width": VIEWPORT_PX, "height": 900})
            page.goto(html.as_uri())
            f["screen"] = page.evaluate(_LAYOUT_JS)
            f["scroll_width"] = page.evaluate("document.documentElement.scrollWidth")
            page.screenshot(path=str(ARTIFACTS / f"report-{name.replace(' ', '-')}.png"),
                            full_page=True)
            page.set_viewport_size({"width": PHONE_PX, "height": 900})
            f["phone"] = page.evaluate(_LAYOUT_JS)
            page.emulate_media(media="print")
            page.set_viewport_size({"width": A4_CONTENT_PX, "height": 1100})
            f["print"] = page.evaluate(_LAYOUT_JS)
            f["errors"] = list(errors)
            pdf = pdfs / f"{name.replace(' ', '-')}.pdf"
            page.pdf(path=str(pdf), prefer_css_page_size=True)
            f["pdf"] = pdf
            out[name] = f
        browser.close()
    for f in out.values():
        pages = _pdf_pages(f["pdf"])
        f["pages"] = pages
        f["page_texts"] = _page_texts(f["pdf"], len(pages))
    return out


@pytest.mark.slow
def test_every_report_kind_is_rendered(rendered):
    assert set(KINDS) <= set(rendered)
    for name, f in rendered.items():
        assert f["errors"] == [], name
        assert f["screen"]["tables"] == f["source"].count("<table") >= 2, name
        assert f["screen"]["figures"] == f["source"].count("<img"), name
    for name in ("demo", "allan", "modulation", "ins-errors", "history", "fit polar-tumble",
                 "history figure", "noise", "thermal triad", "centrifuge-study"):
        assert rendered[name]["screen"]["figures"] >= 1, name
    assert rendered["history"]["screen"]["figures"] > rendered["fit polar-tumble"]["screen"][
        "figures"]


@pytest.mark.slow
@pytest.mark.parametrize("medium", ["screen", "phone", "print"])
def test_no_element_wider_than_its_box_and_no_word_split(rendered, medium):
    """At 1200 px, on a 420 px phone and in A4 print: scrollWidth <= clientWidth for every
    element (no clipped column, no scroll box); no number in a table is split over two lines,
    and a header or caption breaks between words only (or after a word's own hyphen or
    slash: "acceleration-/sensitive", "deg/h/g")."""
    for name, f in rendered.items():
        assert f[medium]["wide"] == [], (name, medium)
        assert f[medium]["split"] == [], (name, medium)
    assert all(f["scroll_width"] <= VIEWPORT_PX for f in rendered.values())


@pytest.mark.slow
def test_every_printed_page_names_the_report_and_says_page_k_of_n(rendered, tmp_path):
    for name, f in rendered.items():
        pages, texts = f["pages"], f["page_texts"]
        assert pages and all((round(w), round(h)) == A4_PT for w, h in pages), (name, pages)
        n = len(pages)
        for k, text in enumerate(texts, 1):
            flat = " ".join(text.split())
            assert f"page {k} of {n}" in flat, (name, k)
            assert f"Report {f['id']}" in flat, (name, k)
            assert "Serial " in flat, (name, k)
        assert f"End of report {f['id']}" in " ".join(texts[-1].split()), name
        assert all(f"End of report {f['id']}" not in t for t in texts[:-1]), name
        folder = tmp_path / name.replace(" ", "-")
        folder.mkdir()
        assert _blank_pages(f["pdf"], folder) == [], name


@pytest.mark.slow
def test_no_number_in_a_table_is_split_in_the_pdf(rendered):
    """Every number printed in a table cell of the HTML is found whole in pdftotext's text
    of the PDF (a number split over two lines would come out as two pieces)."""
    for name, f in rendered.items():
        parser = _CellNumbers()
        parser.feed(f["source"])
        printed = set()
        for text in f["page_texts"]:
            printed.update(m.group() for m in _NUMBER.finditer(text))
        missing = sorted(parser.numbers - printed)
        assert parser.numbers and missing == [], (name, missing[:10])


@pytest.mark.slow
def test_fit_pdf_from_the_command_line_is_a_certificate(reports):
    """``inertest fit --pdf``: the run id (report id) and serial on every page, page k of n,
    the end on the last page, and certificate.json naming the PDF by its SHA-256."""
    import hashlib
    import json

    _chromium()
    _poppler()
    folder = reports["history"].parent
    pdf = folder / "report.pdf"
    cert = json.loads((folder / "certificate.json").read_text())
    rid = cert["report"]["id"]
    assert re.fullmatch(r"[0-9a-f-]{36}", rid)  # the stored run's id
    files = {f["name"]: f["sha256"] for f in cert["report"]["files"]}
    assert files["report.pdf"] == hashlib.sha256(pdf.read_bytes()).hexdigest()
    assert files["index.html"] == hashlib.sha256(reports["history"].read_bytes()).hexdigest()
    texts = _page_texts(pdf, len(_pdf_pages(pdf)))
    for k, text in enumerate(texts, 1):
        flat = " ".join(text.split())
        assert f"page {k} of {len(texts)}" in flat and f"Report {rid}" in flat
        assert "Serial FG-0417" in flat
    assert f"End of report {rid}" in " ".join(texts[-1].split())
