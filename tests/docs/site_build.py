"""Build the documentation site once per test session, shared by the xdist workers."""

from __future__ import annotations

import fcntl
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def build_site(base: Path) -> Path:
    """``mkdocs build --strict`` into ``base/site`` (once: later callers, in any worker, wait for
    the first build and reuse it). Raises with mkdocs' output if the build fails."""
    site = base / "site"
    done = base / "site.ok"
    failed = base / "site.failed"
    with open(base / "site.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists() and not failed.exists():
            env = {**os.environ, "NO_MKDOCS_2_WARNING": "1", "PYTHONPATH": str(ROOT)}
            run = subprocess.run(
                [sys.executable, "-m", "mkdocs", "build", "--strict", "-d", str(site)],
                cwd=ROOT,
                env=env,
                capture_output=True,
                text=True,
                check=False,
            )
            (done if run.returncode == 0 else failed).write_text(run.stdout + run.stderr)
    if failed.exists():
        raise AssertionError("mkdocs build --strict failed:\n" + failed.read_text()[-6000:])
    return site
