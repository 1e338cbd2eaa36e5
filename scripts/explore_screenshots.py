"""Screenshots of every interactive figure after moving a control, at 1280 and 390 px.

    python scripts/explore_screenshots.py OUT_DIR    # serves _site/ on 127.0.0.1; needs Chromium + Selenium

For each figure: the first slider one step right (and, where there is one, the second select to
its second option), the mouse over the middle of the map, then a screenshot of the figure.
"""

from __future__ import annotations

import functools
import http.server
import sys
import threading
import time
from pathlib import Path

from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.action_chains import ActionBuilder
from selenium.webdriver.common.keys import Keys

ROOT = Path(__file__).resolve().parent.parent
PAGES = [
    "p1_gripper_4prr",
    "p2_three_rrr_singularity_proximity",
    "p3_two_t_one_r",
    "p4_five_bar_stiffness",
    "p5_decoupled_6dof_dynamics",
    "design_studies",
]


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(_Quiet, directory=str(ROOT / "_site")))
    threading.Thread(target=server.serve_forever, daemon=True).start()
    o = webdriver.ChromeOptions()
    o.binary_location = "/usr/bin/chromium"
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--force-device-scale-factor=1"):
        o.add_argument(a)
    d = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=o)
    try:
        for width in (1280, 390):
            d.set_window_size(width, 1100)
            for page in PAGES:
                if not (ROOT / "_site" / "notebooks" / f"{page}.html").exists():
                    continue
                d.get(f"http://127.0.0.1:{server.server_address[1]}/notebooks/{page}.html")
                for n, el in enumerate(d.find_elements("css selector", ".pk-explore")):
                    d.execute_script("arguments[0].scrollIntoView({block: 'start'})", el)
                    for _ in range(100):
                        if d.execute_script("return arguments[0].dataset.loading === 'false'", el):
                            break
                        time.sleep(0.1)
                    sliders = el.find_elements("css selector", "input[type=range]")
                    if sliders:
                        sliders[0].send_keys(Keys.ARROW_RIGHT)
                    selects = el.find_elements("css selector", "select")
                    if len(selects) > 1:
                        selects[0].send_keys(Keys.ARROW_DOWN)
                    time.sleep(0.8)
                    canvas = el.find_element("css selector", "canvas")
                    r = d.execute_script("return arguments[0].getBoundingClientRect()", canvas)
                    a = ActionBuilder(d)
                    a.pointer_action.move_to_location(
                        round(r["left"] + r["width"] * 0.45), round(r["top"] + r["height"] * 0.5)
                    )
                    a.perform()
                    time.sleep(0.3)
                    el.screenshot(str(out / f"{page}_{n}_{width}.png"))
                    print(out / f"{page}_{n}_{width}.png", "|", el.find_element("css selector", ".pk-readout").text)
    finally:
        d.quit()
        server.shutdown()


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "runs/explore_screenshots"))
