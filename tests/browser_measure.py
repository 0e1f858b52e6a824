"""Measuring a built docs page in headless Chromium: `measure(site, page, tmp_path, script,
element_id)` injects `script` (which writes JSON into `<pre id=element_id>`) before `</body>`
of a copy of the page beside it (so relative assets load), dumps the DOM at a laptop's
1280 x 900, and returns the JSON."""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

from train_extra import chromium

PROBE_PREFIX = "_probe_"  # the page copies' names: the site's page lists leave them out


def measure(site: Path, page: str, tmp_path: Path, script: str, element_id: str) -> dict:
    """What `script` measured on `page` of the site built under `site`."""
    source = site / page
    probe = source.with_name(f"{PROBE_PREFIX}{element_id}_{tmp_path.name}.html")
    probe.write_text(source.read_text(encoding="utf-8").replace("</body>", script + "</body>"))
    try:
        run = subprocess.run(
            [
                chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                f"--user-data-dir={tmp_path / 'profile'}", "--window-size=1280,900",
                "--virtual-time-budget=5000", "--dump-dom", probe.as_uri(),
            ],
            capture_output=True, text=True, timeout=120, check=False,
        )  # fmt: skip
    finally:
        probe.unlink()
    found = re.search(rf'<pre id="{element_id}">(.*?)</pre>', run.stdout, re.S)
    assert found, f"chromium measured nothing on {page}: {run.stderr[-500:]}"
    return json.loads(
        found.group(1).replace("&lt;", "<").replace("&gt;", ">").replace("&amp;", "&")
    )
