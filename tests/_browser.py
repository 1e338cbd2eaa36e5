"""Shared fixtures of the browser tests: the rendered site served on 127.0.0.1 and one headless
Chromium (Debian's `chromium` and `chromium-driver`, driven by Selenium) for all the pages.

    from _browser import browser, site_url  # noqa: F401  (pytest fixtures)

    def test_x(browser, site_url):
        browser.open(site_url + "index.html", width=390)

The browser resolves no host name but 127.0.0.1 (``--host-resolver-rules``): a page that needs the
network (a CDN script, a web font) fails here as it would offline. It keeps the pages' console
(``goog:loggingPrefs``; read it with ``browser.console()``) and lets a ``file://`` page load the
site's other local files (``--allow-file-access-from-files``), as the interactive figures' test needs. Without _site/ (render it with
``bash scripts/render_site.sh``), Chromium, chromedriver or Selenium the tests skip and say why.
"""

from __future__ import annotations

import functools
import http.server
import shutil
import threading
import time
from pathlib import Path

import pytest
from _site import SITE, wait_for_render

#: The two widths every page is read at: a desktop screen and a phone.
WIDTHS = (1280, 390)
#: No name resolves but the local server's address: the site must work offline.
OFFLINE = "--host-resolver-rules=MAP * ~NOTFOUND , EXCLUDE 127.0.0.1"


def chromium_paths() -> tuple[str, str] | None:
    """(chromium, chromedriver) from PATH or Debian's places, or None."""
    browser = next(
        (
            p
            for p in (shutil.which("chromium"), shutil.which("chromium-browser"), "/usr/bin/chromium")
            if p and Path(p).exists()
        ),
        None,
    )
    driver = next(
        (
            p
            for p in (shutil.which("chromedriver"), "/usr/bin/chromedriver", "/usr/lib/chromium/chromedriver")
            if p and Path(p).exists()
        ),
        None,
    )
    return (browser, driver) if browser and driver else None


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):  # no request log on the test output
        pass


@pytest.fixture(scope="session")
def site_url():
    """The URL (ending in '/') of _site/ served on 127.0.0.1 at a free port for the session (once
    the render beside the tests, if any, has ended: tests/_site.py)."""
    wait_for_render()
    if not (SITE / "index.html").exists():
        pytest.skip("_site/ is not rendered (bash scripts/render_site.sh; needs Quarto)")
    handler = functools.partial(_QuietHandler, directory=str(SITE))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}/"
    server.shutdown()
    server.server_close()


#: Waits for MathJax to typeset (when it loaded) and for every image, lazy ones loaded eagerly.
_SETTLE = """
const done = arguments[arguments.length - 1];
const mj = (window.MathJax && MathJax.startup && MathJax.startup.promise) ? MathJax.startup.promise : Promise.resolve();
const imgs = Array.from(document.images).map(img => {
  img.loading = "eager";
  return img.complete ? Promise.resolve() : new Promise(r => { img.onload = img.onerror = r; });
});
Promise.all([mj.catch(() => null), ...imgs]).then(() => done(true));
"""


class Browser:
    """One headless Chromium; ``open(url, width)`` loads a page at a window width and waits for
    it (and MathJax, when the page has maths) to finish."""

    def __init__(self, driver):
        self.driver = driver
        self.width, self.height = WIDTHS[0], 900

    def open(self, url: str, width: int = 1280, height: int = 900, timeout: float = 20.0):
        d = self.driver
        self.viewport(width, height)
        d.get(url)
        deadline = time.monotonic() + timeout
        while d.execute_script("return document.readyState") != "complete" and time.monotonic() < deadline:
            time.sleep(0.05)
        d.set_script_timeout(max(deadline - time.monotonic(), 1.0))
        d.execute_async_script(_SETTLE)
        return d

    def viewport(self, width: int, height: int = 900):
        """The page's viewport exactly ``width`` x ``height`` CSS pixels (scale 1)."""
        self.driver.execute_cdp_cmd(
            "Emulation.setDeviceMetricsOverride",
            {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False},
        )
        self.width, self.height = width, height

    def console(self) -> list[dict]:
        """The console entries (``level``, ``message``, ``source``) logged since the last call."""
        return self.driver.get_log("browser")

    def js(self, script: str, *args):
        return self.driver.execute_script(script, *args)

    def screenshot(self, path: str | Path, full_page: bool = True):
        d = self.driver
        width, height = self.width, self.height
        if full_page:
            self.viewport(width, min(d.execute_script("return document.documentElement.scrollHeight"), 12000))
            time.sleep(0.3)
        d.save_screenshot(str(path))
        if full_page:
            self.viewport(width, height)


@pytest.fixture(scope="session")
def browser():
    """One headless Chromium for the whole session (skips, saying why, without one)."""
    paths = chromium_paths()
    if paths is None:
        pytest.skip("no chromium and chromedriver (Debian: apt-get install -y chromium chromium-driver)")
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        pytest.skip("selenium is not installed")
    options = webdriver.ChromeOptions()
    options.binary_location = paths[0]
    for arg in (
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--hide-scrollbars",
        "--force-device-scale-factor=1",
        "--allow-file-access-from-files",
        OFFLINE,
    ):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})  # the console, for browser.console()
    driver = webdriver.Chrome(service=Service(paths[1]), options=options)
    driver.set_page_load_timeout(60)
    driver.set_window_size(WIDTHS[0], 900)
    try:
        yield Browser(driver)
    finally:
        driver.quit()
