"""The documentation site as a reader gets it.

- It builds with warnings as errors, by the development page's command run verbatim in a copy of
  docs/ (with the README and the CHANGELOG it includes), and every gallery example runs while it builds, at a
  small size (``LDPIPE_EXAMPLE_POINTS``); each example's page shows its pictures and its runtime.
- In headless Chromium the gallery page's pictures load (``naturalWidth > 0``) and are drawn: a
  screenshot differs from the same page with the images hidden. On every page a reader reads
  (the front page, getting started, the theory, the engine, the guide, the gallery's examples)
  the formulas are typeset by MathJax (no raw ``$`` left; on the theory and engine pages as many
  as their sources write) and nothing is wider than the page: no code block or table scrolls
  sideways in a 1400-pixel window.
- Every ```python block of the README and the pages runs as written, and the README's picture is
  what its example draws.
- What a user reads has no dates, machine loads or tracker references (the changelog may date
  its releases), and the README stays a front door.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib import image

from support.browser import browse, chromium, ink, served
from support.workflow import BUILD_DOCS, BUILT, DOCUMENTATION, ROOT

EXAMPLES = sorted(p.stem for p in (ROOT / "docs/examples").glob("plot_*.py"))
SMALL = "40"  # grid points per axis of the gallery examples in the tests


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """``(html folder, completed build)``: docs/ copied as a clone has it, built by the documented
    command with the running environment as ``.venv``."""
    workdir = tmp_path_factory.mktemp("docs")
    shutil.copytree(ROOT / "docs", workdir / "docs", ignore=shutil.ignore_patterns(*BUILT, "sg_execution_times.rst"))
    for included in ("README.md", "CHANGELOG.md"):  # the front page and the changelog include them
        shutil.copy(ROOT / included, workdir / included)
    (workdir / ".venv").symlink_to(Path(sys.prefix))
    environment = {**os.environ, "LDPIPE_EXAMPLE_POINTS": SMALL, "MPLBACKEND": "Agg"}
    built = subprocess.run(["bash", "-c", BUILD_DOCS], cwd=workdir, env=environment, capture_output=True, text=True,
                           timeout=1800)
    return workdir / "docs/_build/html", built


@pytest.mark.slow
def test_the_site_builds_with_warnings_as_errors(site):
    html, built = site
    assert built.returncode == 0, built.stdout[-3000:] + built.stderr[-5000:]
    for page in ("index", "getting-started", "guide/index", "gallery/index", "configuration", "api", "engine",
                 "architecture", "performance", "development", "changelog"):
        assert (html / f"{page}.html").is_file(), page
    # the configuration reference is generated from the schema: a key from deep inside it is there
    assert "ld_maps.&lt;name&gt;.section.axes[].points" in (html / "configuration.html").read_text()
    # the API reference documents the API: ldpipe.nhim is the stage function
    assert "ldpipe.</span></span><span class=\"sig-name descname\"><span class=\"pre\">nhim</span>" in (
        html / "generated/ldpipe.nhim.html").read_text()


def _drawn(path: Path) -> float:
    """The fraction of a picture's pixels in colour (channels more than 0.1 apart): 0 for an empty
    canvas or empty axes, which are white, black and grey; measured 0.006-0.009 for the gallery's
    line plots and 0.13-0.6 for its maps."""
    pixels = image.imread(path)[..., :3]
    return float((pixels.max(axis=-1) - pixels.min(axis=-1) > 0.1).mean())


def _images(page: Path) -> list[Path]:
    """The image files a built page shows."""
    sources = re.findall(r'<img[^>]* src="([^"]+)"', page.read_text())
    return [(page.parent / source).resolve() for source in sources if not source.startswith(("http", "data:"))]


@pytest.mark.slow
@pytest.mark.parametrize("example", EXAMPLES)
def test_every_gallery_example_ran_and_shows_its_pictures_and_runtime(site, example):
    html, built = site
    assert built.returncode == 0, built.stderr[-3000:]
    page = html / "gallery" / f"{example}.html"
    text = page.read_text()
    assert "Total running time of the script:" in text, f"{example}: no runtime on its page"
    figures = [path for path in _images(page) if path.name.startswith(f"sphx_glr_{example}_")]
    assert figures, f"{example}: no figure on its page"
    for path in figures:
        assert _drawn(path) > 0.002, f"{path.name}: nothing drawn in it"


# Waits for every image of the page (lazy ones made eager), then puts in the title, which --dump-dom
# prints, each image's source, natural width and box on the page (CSS pixels, one per screenshot
# pixel at the browser's device scale factor 1).
REPORT_IMAGES = """<script>
for (const img of document.images) { img.loading = "eager"; }
window.addEventListener("load", () => {
  const done = () => [...document.images].every(i => i.complete);
  const report = () => {
    if (!done()) { setTimeout(report, 50); return; }
    document.title = "images:" + JSON.stringify([...document.images].map(i => {
      const box = i.getBoundingClientRect();
      return [i.getAttribute("src"), i.naturalWidth, [box.left, box.top, box.width, box.height].map(Math.round)];
    }));
  };
  report();
});
</script>
"""
HIDE_IMAGES = "<style>img { visibility: hidden !important; }</style>"


def _with(page: Path, name: str, extra: str) -> Path:
    """A copy of ``page`` beside it (so relative links hold) with ``extra`` before ``</body>``."""
    text = page.read_text()
    end = text.rindex("</body>")
    copy = page.with_name(name)
    copy.write_text(text[:end] + extra + text[end:])
    return copy


@pytest.mark.slow
def test_the_gallery_page_shows_its_pictures_in_a_browser(site, tmp_path):
    html, built = site
    assert built.returncode == 0, built.stderr[-3000:]
    browser = chromium()
    if browser is None:
        pytest.skip("no chromium on this machine (.ci/run installs Debian's chromium where it runs as root)")
    gallery = html / "gallery/index.html"
    profile = tmp_path / "chromium-profile"

    dom = browse(browser, _with(gallery, "loaded.html", REPORT_IMAGES).as_uri(), profile)
    title = re.search(r"<title>images:(.*?)</title>", dom, flags=re.S)
    assert title, "the page's images never finished loading"
    shown = json.loads(title.group(1).replace("&amp;", "&").replace("&quot;", '"'))
    thumbnails = [(src, width, box) for src, width, box in shown if "sphx_glr_" in src]
    assert len(thumbnails) == len(EXAMPLES), shown  # one thumbnail per example
    assert all(width > 0 for _, width, _ in thumbnails), f"images that did not load: {thumbnails}"

    # The screenshot is not blank where each picture is: there it differs from the same page with
    # its images hidden (measured: 10-22 % of a line plot's box, 20-40 % of a map's).
    shown_png, hidden_png = tmp_path / "shown.png", tmp_path / "hidden.png"
    browse(browser, gallery.as_uri(), profile, screenshot=shown_png)
    browse(browser, _with(gallery, "hidden.html", HIDE_IMAGES).as_uri(), profile, screenshot=hidden_png)
    shot, control = image.imread(shown_png), image.imread(hidden_png)
    assert shot.shape == control.shape and ink(shot, np.ones(3)).any(), "a blank screenshot"
    differs = ink(shot, control)
    for src, _, (left, top, width, height) in thumbnails:
        assert width > 50 and height > 30 and top + height <= shot.shape[0], f"{src}: drawn at {width} x {height}"
        drawn = differs[top:top + height, left:left + width].mean()
        assert drawn > 0.03, f"{src}: only {drawn:.1%} of its box on the screen shows it"


#: Loads each page a reader reads (PAGES) in a 1400-pixel-wide iframe, one after another, and once
#: its scripts (MathJax) have finished records the formulas typeset, text that still holds TeX
#: delimiters outside code, and code blocks or tables wider than their box; the results go to the
#: title, which the dumped DOM carries back.
READING_PROBE = """<!doctype html><html><head><title>waiting</title></head><body style="margin: 0"><script>
const pages = PAGES;
function read(url) {
  return new Promise(resolve => {
    const frame = document.createElement('iframe');
    Object.assign(frame.style, {width: '1400px', height: '1800px', border: '0'});
    frame.onload = async () => {
      const view = frame.contentWindow, page = frame.contentDocument;
      if (view.MathJax && view.MathJax.startup) { await view.MathJax.startup.promise; }
      const article = page.querySelector('article') || page.body;
      const walker = page.createTreeWalker(article, NodeFilter.SHOW_TEXT);
      const raw = [];
      while (walker.nextNode()) {
        const node = walker.currentNode;
        if (node.parentElement.closest('pre, code, script, style, mjx-container')) continue;
        if (/\\$[^$\\s]|\\\\\\(|\\\\\\[/.test(node.textContent)) raw.push(node.textContent.trim().slice(0, 80));
      }
      const wide = [];
      for (const box of article.querySelectorAll('pre, table')) {
        if (box.scrollWidth > box.clientWidth + 1) {
          wide.push(`${box.tagName} ${box.scrollWidth - box.clientWidth} px too wide: ${box.textContent.trim().slice(0, 60)}`);
        }
      }
      const overflow = page.documentElement.scrollWidth - page.documentElement.clientWidth;
      const math = page.querySelectorAll('mjx-container').length;
      frame.remove();
      resolve({math, raw, wide, overflow});
    };
    frame.src = url;
    document.body.appendChild(frame);
  });
}
(async () => {
  const readings = {};
  for (const url of pages) { readings[url] = await read(url); }
  document.title = 'reading:' + JSON.stringify(readings);
})();
</script></body></html>"""


def _reader_pages(html: Path) -> list[str]:
    pages = [html / "index.html", html / "getting-started.html", html / "theory.html", html / "engine.html",
             *sorted((html / "guide").glob("*.html")), *sorted((html / "gallery").glob("plot_*.html"))]
    return [str(page.relative_to(html)) for page in pages]


def _formulas(page: str) -> int:
    """How many formulas the page's source writes in dollar math (outside code): each ``$$`` block
    and each inline ``$...$`` one formula."""
    prose = re.sub(r"^```.*?^```", "", (ROOT / "docs" / Path(page).with_suffix(".md")).read_text(), flags=re.S | re.M)
    prose = re.sub(r"`[^`\n]*`", "", prose)
    display = len(re.findall(r"^\$\$.*?^\$\$", prose, flags=re.S | re.M))
    return display + len(re.findall(r"\$[^$\s][^$]*?\$", re.sub(r"^\$\$.*?^\$\$", "", prose, flags=re.S | re.M)))


def _states_math(page: str) -> bool:
    """Whether the page's source writes a formula in dollar math (outside code)."""
    source = ROOT / "docs" / Path(page).with_suffix(".md")
    if not source.is_file():
        return False
    prose = re.sub(r"^```.*?^```", "", source.read_text(), flags=re.S | re.M)
    return re.search(r"\$[^$\s][^$]*\$", prose) is not None


@pytest.mark.slow
def test_formulas_are_typeset_and_no_page_is_wider_than_the_window(site, tmp_path):
    html, built = site
    assert built.returncode == 0, built.stderr[-3000:]
    browser = chromium()
    if browser is None:
        pytest.skip("no chromium on this machine (.ci/run installs Debian's chromium where it runs as root)")
    pages = _reader_pages(html)
    assert len(pages) > 20 and all((html / page).is_file() for page in pages)
    (html / "reading.html").write_text(READING_PROBE.replace("PAGES", json.dumps(pages)))
    with served(html) as site_url:
        dom = browse(browser, f"{site_url}/reading.html", tmp_path / "chromium-profile")
    found = re.search(r"<title>reading:(.*?)</title>", dom, flags=re.S)
    assert found, "the pages' scripts never finished"
    text = found.group(1)
    for entity, character in (("&quot;", '"'), ("&lt;", "<"), ("&gt;", ">"), ("&amp;", "&")):
        text = text.replace(entity, character)
    readings = json.loads(text)
    assert sorted(readings) == sorted(pages)
    for page, reading in readings.items():
        assert not reading["raw"], f"{page}: TeX left untypeset: {reading['raw']}"
        assert reading["overflow"] <= 0 and not reading["wide"], f"{page}: wider than the window: {reading['wide']}"
        if _states_math(page):
            assert reading["math"] > 0, f"{page}: its formulas were not typeset"
    assert readings["theory.html"]["math"] >= 40  # every formula of the theory page typeset
    for page in ("theory.html", "engine.html"):  # every formula their sources write (a heading's twice)
        assert readings[page]["math"] >= _formulas(page) > 40, page


# ------------------------------------------------------------------------ the pages' Python

PYTHON_BLOCKS = sorted({block for text in DOCUMENTATION.values()
                        for block in re.findall(r"^```python\n(.*?)^```", text, flags=re.S | re.M)})


def test_the_readme_and_getting_started_show_the_same_ten_line_example():
    readme, = re.findall(r"^```python\n(.*?)^```", DOCUMENTATION["README.md"], flags=re.S | re.M)
    assert readme in DOCUMENTATION["docs/getting-started.md"]
    assert len(readme.strip().splitlines()) <= 12  # ten lines of code, and the imports' blank line


@pytest.mark.parametrize("block", PYTHON_BLOCKS, ids=[b.splitlines()[-1][:40] for b in PYTHON_BLOCKS])
def test_every_python_block_runs_as_written(block, tmp_path, monkeypatch, capsys):
    """In a folder with the clone's ``src`` (a block may read the sources, as engine.md's does),
    so that what a block writes stays out of the repository."""
    (tmp_path / "src").symlink_to(ROOT / "src")
    monkeypatch.chdir(tmp_path)
    exec(compile(block, "<documentation>", "exec"), {"__name__": "__main__"})
    plt.close("all")
    if "print(" in block:
        assert capsys.readouterr().out.strip(), "the block printed nothing"
    for saved in tmp_path.glob("*.png"):
        assert _drawn(saved) > 0.002, f"{saved.name}: nothing drawn in it"
    if saved := next(tmp_path.glob("henon_heiles_ld.png"), None):
        # The README's picture is what its example draws (the same renderer: pixel for pixel but
        # for antialiasing, well within 1 % on average).
        committed = image.imread(ROOT / "docs/_static/henon_heiles_ld.png")
        drawn = image.imread(saved)
        assert drawn.shape == committed.shape
        assert np.abs(drawn - committed).mean() < 0.01


# ------------------------------------------------------------------------ what a user reads

def _user_text() -> dict[str, str]:
    """The README, the pages (Markdown and reStructuredText) and the gallery's scripts."""
    pages = {**DOCUMENTATION}
    for path in [*(ROOT / "docs").rglob("*.rst"), *(ROOT / "docs/examples").glob("*.py")]:
        if not BUILT & set(path.relative_to(ROOT).parts) and path.name != "sg_execution_times.rst":
            pages[str(path.relative_to(ROOT))] = path.read_text()
    return pages


def test_what_a_user_reads_has_no_dates_loads_or_tracker_references():
    forbidden = {
        # the example data's calendar is the year 2000 (days since 2000-01-01): its dates are data
        "a date": r"\b20(?!00-)\d\d-[01]\d-[0-3]\d\b",
        "a tracker reference": r"\b[Ii]ssues? #?\d+",
        "a machine load": r"\bload(?: average)? (?:of |~)?\d",
        "a commit": r"\b(?:at|main|commit) [0-9a-f]{7,40}\b",
    }
    found = [f"{path}: {what}: {match.group(0)!r}" for path, text in _user_text().items()
             for what, pattern in forbidden.items() for match in re.finditer(pattern, text)]
    assert not found, found


def test_the_readme_is_a_front_door():
    readme = DOCUMENTATION["README.md"]
    assert len(readme.splitlines()) <= 150
    pictures = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", readme)
    assert len(pictures) == 1 and (ROOT / pictures[0]).is_file()
    assert (ROOT / pictures[0]).stat().st_size < 200_000  # a small PNG
    for link in re.findall(r"\]\(((?:docs|benchmarks)/[^)#]+|CHANGELOG\.md)\)", readme):
        assert (ROOT / link).is_file(), f"the README links to {link}, which is not there"


def test_the_site_front_page_includes_the_readme_introduction_rather_than_repeating_it():
    """The introduction is written once, in the README (what GitHub shows), between two markers;
    docs/index.md includes that part, so the two front pages cannot drift apart."""
    readme, index = DOCUMENTATION["README.md"], DOCUMENTATION["docs/index.md"]
    start, end = "<!-- introduction-start -->", "<!-- introduction-end -->"
    assert readme.count(start) == readme.count(end) == 1 and readme.index(start) < readme.index(end)
    include = re.search(r"^```\{include\} \.\./README\.md\n(.*?)^```", index, flags=re.S | re.M)
    assert include and f":start-after: {start}" in include.group(1) and f":end-before: {end}" in include.group(1)
    introduction = readme.split(start)[1].split(end)[0]
    first_words = " ".join(introduction.split()[:8])
    assert first_words not in " ".join(index.split()), "docs/index.md repeats the README's introduction"
