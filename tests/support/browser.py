"""Headless Chromium for the tests that look at a page as a reader would: the Snakemake report
(tests/workflow/test_report.py) and the documentation site (tests/docs/test_docs.py)."""

from __future__ import annotations

import contextlib
import functools
import shutil
import subprocess
import threading
from concurrent.futures import ThreadPoolExecutor
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import numpy as np


def chromium() -> str | None:
    """The Chromium on PATH, or None where there is none (a machine that has one must run it)."""
    return next((shutil.which(name) for name in ("chromium", "chromium-browser") if shutil.which(name)), None)


def browse(browser: str, url: str, profile: Path, *, screenshot: Path | None = None,
           window: tuple[int, int] = (1400, 1800)) -> str:
    """Open ``url`` in headless Chromium in a ``window`` (width, height) of CSS pixels: its DOM after
    the scripts ran, or a screenshot. A browser that will not start fails the calling test (it
    does not skip)."""
    action = [f"--screenshot={screenshot}"] if screenshot else ["--dump-dom"]

    def run(user_data: Path) -> subprocess.CompletedProcess:
        return subprocess.run(
            [browser, "--headless", "--no-sandbox", "--disable-gpu", f"--user-data-dir={user_data}",
             "--virtual-time-budget=10000", "--force-device-scale-factor=1", f"--window-size={window[0]},{window[1]}",
             *action, url],
            capture_output=True, text=True, timeout=180,
        )

    try:
        result = run(profile)
    except subprocess.TimeoutExpired:
        # headless Chromium now and then never returns from a page's virtual time: a second
        # launch, on a fresh profile, is the same test; a browser that hangs twice fails it
        result = run(profile.with_name(profile.name + "-again"))
    assert result.returncode == 0, result.stderr[-2000:]
    return result.stdout


def browse_all(browser: str, launches: list[tuple[str, Path | None]], profiles: Path, *,
               at_once: int = 3) -> list[str]:
    """``browse`` each (url, screenshot or None) of ``launches``, ``at_once`` browsers at a time, in
    the order given. A launch spends much of its time starting up and waiting, so a few side by side
    finish sooner even on two cores; each gets its own profile, as Chromium locks one to a browser."""
    def launch(number: int, url: str, screenshot: Path | None) -> str:
        return browse(browser, url, profiles / str(number), screenshot=screenshot)

    with ThreadPoolExecutor(at_once) as pool:
        return list(pool.map(launch, range(len(launches)), *zip(*launches)))


class _QuietHandler(SimpleHTTPRequestHandler):
    def log_message(self, *arguments) -> None:  # the test's output is the assertions', not each request
        pass


@contextlib.contextmanager
def served(folder: Path):
    """``folder`` served over HTTP on localhost while the block runs; yields its base URL. A page
    that reads other pages' DOM through iframes must share their origin, which file:// pages do not."""
    server = ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(_QuietHandler, directory=str(folder)))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()
        thread.join()


def ink(pixels: np.ndarray, background: np.ndarray) -> np.ndarray:
    """Where an RGB image differs from ``background`` (same shape, or one colour) by more than 2 %."""
    return np.any(np.abs(pixels[..., :3] - background[..., :3]) > 0.02, axis=-1)
