"""The Snakemake report: the main install can build it, its captions are clean
reStructuredText, and built from the quick run it shows every figure in a real browser."""

from __future__ import annotations

import base64
import io
import json
import re
from importlib import metadata
from pathlib import Path

import numpy as np
import pytest
from docutils.core import publish_parts
from matplotlib import image
from packaging.requirements import Requirement

from support.browser import browse_all, chromium, ink
from support.workflow import ROOT, run_snakemake

# docutils' system messages as it prints them, e.g. "(ERROR/3) Undefined substitution referenced"
DOCUTILS_MESSAGE = re.compile(r"\((DEBUG|INFO|WARNING|ERROR|SEVERE)/\d\)")


def _requirement_closure(name: str) -> set[str]:
    """Every distribution ``name`` installs without extras, from the installed metadata."""
    seen, todo = set(), [name]
    while todo:
        current = todo.pop()
        key = current.lower().replace("_", "-")
        if key in seen:
            continue
        seen.add(key)
        for text in metadata.requires(current) or []:
            requirement = Requirement(text)
            if requirement.marker is None or requirement.marker.evaluate({"extra": ""}):
                todo.append(requirement.name)
    return seen


def test_the_main_install_has_what_snakemake_report_needs():
    # snakemake --report imports jinja2, docutils and pygments (the last only when it builds the
    # report, so a missing one fails there); ldpipe's own requirements must bring all three.
    closure = _requirement_closure("ldpipe")
    assert {"snakemake", "jinja2", "docutils", "pygments"} <= closure
    assert "pytest" not in closure  # ... and not through the test extras


@pytest.mark.parametrize("caption", sorted(p.name for p in (ROOT / "workflow/report").glob("*.rst")))
def test_plain_captions_render_without_docutils_messages(caption):
    """The captions that are not templates (tests/stages/test_figures.py renders the templates)."""
    text = (ROOT / "workflow/report" / caption).read_text()
    if "{{" in text:
        pytest.skip("a Jinja template over the figure's params: rendered in tests/stages/test_figures.py")
    stream = io.StringIO()
    html = publish_parts(text, writer="html", settings_overrides={"report_level": 1, "warning_stream": stream})["body"]
    assert stream.getvalue() == "" and "System Message" not in html, stream.getvalue()


# Shows the result named in the URL's hash exactly as the result's "view" button does (the report
# is a single-page app without routes: `app` and `results` are its globals); with "?bare" the
# navigation bar is hidden as its own hide button does, so a screenshot holds the figure alone.
# The bar slides out with a CSS transition, which a screenshot on a busy machine can catch still
# on screen, so the bare view switches transitions off and the bar goes at once.
SHOW_RESULT = """<script>
if (location.search === "?bare") {
  const still = document.createElement("style");
  still.textContent = "*, *::before, *::after { transition: none !important; animation: none !important; }";
  document.head.appendChild(still);
}
function ldpipeShow() {
  if (typeof app === "undefined" || !app) { setTimeout(ldpipeShow, 50); return; }
  const path = decodeURIComponent(location.hash.slice(1));
  const entry = results[path];
  app.setView({content: "img", contentPath: entry ? entry.data_uri : "", navbarMode: "resultinfo",
               resultPath: entry ? path : undefined, hideNavbar: location.search === "?bare"});
  document.title = "shown:" + path;
}
window.addEventListener("load", ldpipeShow);
</script>
"""


def _view(page: Path, fragment: str, *, bare: bool = False) -> str:
    """The URL of ``page#fragment``; ``bare``: the view without the navigation bar."""
    return page.as_uri() + ("?bare" if bare else "") + "#" + fragment


@pytest.mark.slow
def test_the_report_of_the_quick_run_shows_every_figure_in_a_browser(quick_run, tmp_path):
    workdir, run = quick_run
    assert run.returncode == 0, run.stderr[-3000:]
    report = tmp_path / "report.html"
    # the README's command, against the quick configuration of the run
    built = run_snakemake(workdir, "--report", str(report), "--configfile=config.quick.yaml", timeout=900)
    assert built.returncode == 0, built.stderr[-3000:]
    messages = [line for line in (built.stdout + built.stderr).splitlines() if DOCUTILS_MESSAGE.search(line)]
    assert not messages, messages  # e.g. a caption's |...| read as a substitution
    html = report.read_text()
    results = json.loads(re.search(r'<script id="results">\s*var results = (.*?);\s*</script>', html, re.S).group(1))

    # Every figure the run made is in the report, embedded byte for byte.
    figures = sorted(str(p.relative_to(workdir)) for p in (workdir / "results/figures").glob("*.png"))
    assert len(figures) >= 8 and set(figures) <= set(results)
    for path in figures:
        uri = results[path]["data_uri"]
        assert uri.startswith("data:image/png") and base64.b64decode(uri.split(",", 1)[1]) == (workdir / path).read_bytes()

    browser = chromium()
    if browser is None:
        pytest.skip("no chromium on this machine (.ci/run installs Debian's chromium where it runs as root)")
    page = tmp_path / "view.html"
    end = html.rindex("</body>")
    page.write_text(html[:end] + SHOW_RESULT + html[end:])
    profiles = tmp_path / "chromium-profiles"

    # Control: the same view with no image. A figure's view differs from it where the figure is:
    # a box of the figure's aspect ratio (from the PNG file), inked about as densely as the file.
    # Each figure is opened twice: its DOM in the normal view (with the caption), a screenshot of
    # the bare one. The launches are independent, so they all run first, side by side.
    shots = [tmp_path / (Path(path).stem + ".png") for path in figures]
    launches = [(_view(page, "none", bare=True), tmp_path / "blank.png")]
    for path, shot in zip(figures, shots):
        launches += [(_view(page, path), None), (_view(page, path, bare=True), shot)]
    doms = browse_all(browser, launches, profiles)[1::2]
    blank = image.imread(tmp_path / "blank.png")
    for path, dom, shot in zip(figures, doms, shots):
        assert f"<title>shown:{path}</title>" in dom
        shown = re.findall(r'<img src="(data:image/png[^"]*)"', dom)
        assert shown == [results[path]["data_uri"]], f"{path}: the view does not show the figure's image"
        assert results[path]["caption"][:40] in dom  # the caption is shown beside it
        inked = ink(image.imread(shot), blank)
        inked[:60, :60] = False  # the navigation bar's "show" button, drawn once the bar is hidden
        assert inked.any(), f"{path}: the view is blank"
        rows, columns = np.nonzero(inked.any(axis=1))[0], np.nonzero(inked.any(axis=0))[0]
        box = inked[rows[0]:rows[-1] + 1, columns[0]:columns[-1] + 1]
        figure = image.imread(workdir / path)
        assert box.shape[1] >= 300, f"{path}: drawn only {box.shape[1]} px wide"
        np.testing.assert_allclose(box.shape[1] / box.shape[0], figure.shape[1] / figure.shape[0], rtol=0.1,
                                   err_msg=f"{path}: the drawn box has not the figure's aspect ratio")
        density, expected = box.mean(), ink(figure, np.ones(3)).mean()
        assert 0.5 < density / expected < 2, f"{path}: {density:.1%} of the box inked, the figure has {expected:.1%}"
