"""The rendered site's readiness, for every test that reads _site/.

``make test`` renders the site beside the unit tests (scripts/tests_beside_render.sh), not before
them; that script names, in ``PKMLIB_RENDER_STATUS``, the file to which it writes the render's
exit status when the render ends. :func:`wait_for_render` waits for that file: it returns when the
render succeeded, skips (saying why) when it found no Quarto, and fails with the render's output
when it failed or warned. Without ``PKMLIB_RENDER_STATUS`` (a bare ``pytest``), _site/ is as it is.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SITE = ROOT / "_site"
#: The render takes about 100 s alone; on a loaded machine a few times that.
TIMEOUT_S = 1800.0


def wait_for_render(timeout: float = TIMEOUT_S) -> None:
    status = os.environ.get("PKMLIB_RENDER_STATUS")
    if not status:
        return
    path = Path(status)
    deadline = time.monotonic() + timeout
    while not path.exists():
        if time.monotonic() > deadline:
            pytest.fail(f"the site render beside the tests did not end in {timeout:.0f} s (no {path})")
        time.sleep(0.5)
    rc = int(path.read_text().strip() or "1")
    out = path.with_name(".render.out")
    said = out.read_text(errors="replace") if out.exists() else ""
    if rc == 3:
        pytest.skip(f"no Quarto: {said.strip()[-500:]}")
    if rc != 0:
        pytest.fail(f"scripts/render_site.sh failed or warned (exit {rc}):\n{said[-4000:]}")
