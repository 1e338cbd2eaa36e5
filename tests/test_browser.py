"""The rendered site read as a reader reads it: every page of _site/ opened in headless Chromium
(offline: no host resolves but 127.0.0.1) at 1280 and 390 px, in one browser session.

Each page at each width: the page does not scroll sideways, and nothing sticks out of the window
unless it sits in a box that scrolls by itself (a wide table, an output block); every image has
loaded; no raw TeX is left once MathJax has run (it is served with the site). Over all pages: every
internal link resolves, its #anchor included. Each paper page's verdict box holds every row of the
paper's scorecard that is not reproduced. Each figure's smallest text is at least 10 px as shown at
1280 px, and each figure's "arrays (.npz)" link downloads its file.

Needs _site/ (bash scripts/render_site.sh), Debian's chromium and chromium-driver, and Selenium;
skips, saying why, without them (tests/_browser.py).
"""

from __future__ import annotations

import re
import urllib.request
from pathlib import Path
from urllib.parse import urldefrag, urlsplit

import pytest
from _browser import WIDTHS, browser, site_url  # noqa: F401  (pytest fixtures)
from _site import ROOT, SITE, wait_for_render


def pages() -> list[str]:
    """The rendered pages (paths under _site/), once the render beside the tests, if any, has ended."""
    wait_for_render()
    return sorted(str(p.relative_to(SITE)) for p in SITE.rglob("*.html") if "site_libs" not in p.parts)


def notebook_pages() -> list[str]:
    return [p for p in pages() if p.startswith("notebooks/")]


#: What each page shows to the browser, read once per width: overflow, clipped elements, images,
#: leftover TeX, links and ids.
READ_PAGE = r"""
const W = window.innerWidth;
const out = {innerWidth: W, scrollWidth: document.documentElement.scrollWidth, clipped: [], images: [], tex: [],
             links: [], ids: Array.from(document.querySelectorAll('[id]')).map(e => e.id)};
const scrolls = el => { for (let p = el.parentElement; p && p !== document.body; p = p.parentElement) {
    const o = getComputedStyle(p).overflowX; if (o === 'auto' || o === 'scroll') return true; } return false; };
const hidden = el => { for (let p = el; p; p = p.parentElement) { const s = getComputedStyle(p);
    if (s.display === 'none' || s.visibility === 'hidden') return true; } return !el.getClientRects().length; };
const main = document.querySelector('main') || document.body;
for (const el of main.querySelectorAll('*')) {
  const r = el.getBoundingClientRect();
  if (r.width === 0 || r.height === 0) continue;
  if ((r.right > W + 1 || r.left < -1) && !scrolls(el) && !hidden(el) && !el.closest('mjx-assistive-mml')) {
    out.clipped.push(el.tagName.toLowerCase() + (el.className && typeof el.className === 'string' ? '.' +
      el.className.split(' ').join('.') : '') + ' [' + Math.round(r.left) + ', ' + Math.round(r.right) + '] ' +
      (el.textContent || el.getAttribute('src') || '').trim().slice(0, 50));
  }
}
for (const img of document.images) {
  if (!(img.complete && img.naturalWidth > 0)) out.images.push(img.getAttribute('src'));
}
for (const m of document.querySelectorAll('span.math, div.math')) {
  if (!m.querySelector('mjx-container') && !m.closest('mjx-container')) out.tex.push(m.textContent.slice(0, 60));
}
const walker = document.createTreeWalker(main, NodeFilter.SHOW_TEXT);
for (let n = walker.nextNode(); n; n = walker.nextNode()) {
  const p = n.parentElement;
  if (!p || p.closest('pre, code, script, style, mjx-container, .math, details:not([open]) > :not(summary)')) continue;
  if (/\\\(|\\\[|\$[^$\s][^$]*\\[a-zA-Z]+[^$]*\$/.test(n.textContent) && !hidden(p)) out.tex.push(n.textContent.trim().slice(0, 60));
}
for (const a of document.querySelectorAll('a[href]')) {
  const h = a.getAttribute('href');
  if (h && !h.startsWith('javascript:') && !h.startsWith('mailto:')) out.links.push([h, a.href]);
}
return out;
"""

#: The verdict box's links (null without a box).
READ_VERDICT = """
const box = document.querySelector('main .callout');
return box ? Array.from(box.querySelectorAll('a[href]')).map(a => a.getAttribute('href')) : null;
"""

#: Per figure cell on the page: the figures it saves (data-figures, scripts/figure_arrays.lua) and
#: the displayed width of each of its images.
READ_FIGURES = """
return Array.from(document.querySelectorAll('main div.cell[data-figures]')).map(cell => [
  cell.dataset.figures.split(' '),
  Array.from(cell.querySelectorAll('figure img')).map(img => [img.getAttribute('src'), img.getBoundingClientRect().width])
]);
"""

#: Fetches every "arrays (.npz)" link of the page, as the browser resolves it: [href, status, bytes].
FETCH_ARRAYS = """
const done = arguments[arguments.length - 1];
const links = Array.from(document.querySelectorAll('main a.figure-arrays[href]'));
Promise.all(links.map(a => fetch(a.href).then(r => r.arrayBuffer().then(b => [a.getAttribute('href'), r.status, b.byteLength]))
  .catch(e => [a.getAttribute('href'), 0, 0]))).then(done);
"""

_SEEN: dict[str, dict] = {}  # page -> what it showed at WIDTHS[0], read once for every test


def read(browser, site_url, page, width):  # noqa: F811
    """What the page shows at ``width``; at the page width (1280 px) also its verdict box's links,
    its figures' displayed widths and its arrays links fetched, kept for the other tests: one page
    load per page and width for the whole file."""
    browser.open(site_url + page, width=width)
    seen = browser.js(READ_PAGE)
    if width == WIDTHS[0]:
        seen["verdict"] = browser.js(READ_VERDICT)
        seen["figures"] = browser.js(READ_FIGURES)
        seen["arrays"] = browser.driver.execute_async_script(FETCH_ARRAYS)
        _SEEN[page] = seen
    return seen


def at_page_width(browser, site_url, page):  # noqa: F811
    """What ``page`` showed at 1280 px (read now if no test has read it yet)."""
    return _SEEN[page] if page in _SEEN else read(browser, site_url, page, WIDTHS[0])


@pytest.mark.parametrize("width", WIDTHS)
def test_every_page_fits_the_window_and_shows_everything(browser, site_url, width):  # noqa: F811
    assert pages(), "no rendered page"
    failures = []
    for page in pages():
        seen = read(browser, site_url, page, width)
        assert seen["innerWidth"] == width, f"the viewport is {seen['innerWidth']} px, not {width}"
        if seen["scrollWidth"] > seen["innerWidth"]:
            failures.append(f"{page} @ {width}px: the page scrolls sideways ({seen['scrollWidth']} > {width} px)")
        if seen["clipped"]:
            failures.append(
                f"{page} @ {width}px: {len(seen['clipped'])} elements stick out of the window, e.g. "
                + "; ".join(seen["clipped"][:3])
            )
        if seen["images"]:
            failures.append(f"{page} @ {width}px: images not loaded: {seen['images'][:3]}")
        if seen["tex"]:
            failures.append(f"{page} @ {width}px: raw TeX after load (MathJax missing?): {seen['tex'][:3]}")
    assert not failures, "\n".join(failures)


def test_every_internal_link_and_anchor_resolves(browser, site_url):  # noqa: F811
    for page in pages():
        at_page_width(browser, site_url, page)
    ids = {site_url + page: set(seen["ids"]) for page, seen in _SEEN.items()}
    for page in [p for p in pages() if p.endswith("index.html")]:  # "dir/" serves dir/index.html
        ids[site_url + page[: -len("index.html")]] = ids[site_url + page]
    checked: dict[str, bool] = {}
    broken = []
    for page, seen in sorted(_SEEN.items()):
        for raw, absolute in seen["links"]:
            if not absolute.startswith(site_url):
                continue  # another site
            url, fragment = urldefrag(absolute)
            if url not in checked:
                if url in ids:
                    checked[url] = True
                else:
                    try:
                        with urllib.request.urlopen(urllib.request.Request(url, method="HEAD"), timeout=10) as r:
                            checked[url] = r.status == 200
                    except OSError:
                        checked[url] = False
            if not checked[url]:
                broken.append(f"{page}: {raw} (no such file)")
            elif fragment and url in ids and fragment not in ids[url]:
                broken.append(f"{page}: {raw} (no #{fragment} on {urlsplit(url).path})")
    assert not broken, f"{len(broken)} broken links:\n" + "\n".join(sorted(set(broken))[:40])


def test_no_page_loads_anything_from_the_network():
    """Every script, stylesheet and font the pages load is served with the site (MathJax too)."""
    external = re.compile(r"<(?:script|link|img|iframe)\b[^>]*\b(?:src|href)=\"(https?:)?//[^\"]+\"", re.I)
    if not pages():
        pytest.skip("_site/ is not rendered")
    for page in pages():
        html = (SITE / page).read_text(encoding="utf-8")
        found = [
            m.group(0)[:120]
            for m in external.finditer(html)
            if not re.search(r"rel=\"(?:canonical|alternate)\"", m.group(0))
        ]
        assert not found, f"{page} loads from the network: {found[:3]}"


def test_every_verdict_box_holds_every_row_that_is_not_reproduced(browser, site_url):  # noqa: F811
    from pkmlib.tools.report import (
        NOT_REPRODUCED,
        load_reference,
        load_results,
        row_id,
        scorecard,
    )

    reference = load_reference()
    card = scorecard(reference, load_results())
    for paper, rows in card.items():
        page = str(Path(reference[paper]["notebook"]).with_suffix(".html"))
        hrefs = at_page_width(browser, site_url, page)["verdict"]
        assert hrefs is not None, f"{page}: no verdict box"
        anchors = {urlsplit(h).fragment for h in hrefs if "scorecard.html#" in h}
        for r in rows:
            if r["status"] in NOT_REPRODUCED:
                assert row_id(paper, r["quantity"]) in anchors, (
                    f"{page}: the verdict box does not show {r['quantity']!r} ({r['status']})"
                )


#: Every figure's smallest text as displayed on the 1280 px page, in CSS px (issue 20.6).
MIN_TEXT_PX = 10.0


def png_text_px(path: Path) -> tuple[float | None, int]:
    """(MinTextPx from the PNG's metadata, or None when it has none; the PNG's width in px)."""
    from PIL import Image

    with Image.open(path) as im:
        value = im.info.get("MinTextPx")
        return (float(value) if value is not None else None), im.size[0]


def test_every_figures_smallest_text_is_at_least_10_px_at_page_width(browser, site_url):  # noqa: F811
    """At 1280 px, each figure's smallest text is at least 10 CSS px as displayed. The saved PNG
    (figures/<name>.png, pkmlib.plotting.save_figure) records MinTextPx, the pixel height of its
    smallest text at its own resolution; the page shows the same figure scaled to its displayed
    width, so the text is MinTextPx * displayed width / the saved PNG's width. A PNG without
    MinTextPx (saved before save_figure recorded it) fails too, naming the file."""
    assert notebook_pages(), "no rendered notebook page"
    failures, checked = [], 0
    for page in notebook_pages():
        for names, images in at_page_width(browser, site_url, page)["figures"]:
            if len(images) != len(names):
                failures.append(f"{page}: a cell saves {names} but shows {len(images)} images")
                continue
            for name, (src, shown) in zip(names, images):
                png = ROOT / "figures" / f"{name}.png"
                if not png.exists():
                    failures.append(f"{page}: {src}: figures/{name}.png is missing")
                    continue
                min_px, width = png_text_px(png)
                if min_px is None:
                    failures.append(f"figures/{name}.png: no MinTextPx metadata (saved before save_figure recorded it)")
                    continue
                checked += 1
                displayed = min_px * shown / width
                if displayed < MIN_TEXT_PX:
                    failures.append(
                        f"figures/{name}.png: smallest text {displayed:.1f} px at 1280 px "
                        f"(MinTextPx {min_px:g} of {width} px, shown {shown:.0f} px wide) < {MIN_TEXT_PX:g} px"
                    )
    assert not failures, f"{len(failures)} figures (of {checked} measured) too small to read:\n" + "\n".join(failures)


def test_every_arrays_link_downloads_its_npz(browser, site_url):  # noqa: F811
    """Each figure's "arrays (.npz)" link (scripts/figure_arrays.lua) resolves in the browser to
    the file figures/<name>.npz of the repository, byte for byte in length."""
    links = 0
    for page in notebook_pages():
        for href, status, size in at_page_width(browser, site_url, page)["arrays"]:
            links += 1
            name = Path(urlsplit(href).path).name
            assert status == 200, f"{page}: {href}: HTTP {status}"
            assert size == (ROOT / "figures" / name).stat().st_size, f"{page}: {href}: {size} bytes"
    npz = sorted((ROOT / "figures").glob("*.npz"))
    if not npz:
        pytest.skip("no figures/*.npz yet: no arrays link to follow")
    assert links >= len(npz), f"{links} arrays links on the pages for {len(npz)} figures/*.npz"
