"""One writer per dataset id: a claim file created exclusively before collecting.

Two `fluids-bench collect` runs into the same new id both passed the "does it exist?" check
(it did not, yet), both collected, and the second silently replaced the first. A claim closes
that window from the start: `O_CREAT | O_EXCL` is atomic on a local file system (and on NFS
v3+), so of two runs racing for one id exactly one creates the claim and the other is refused
before it collects anything. The claim holds `host pid`; a claim whose process is gone (a run
killed with SIGKILL, which runs no clean-up) is taken over. The export's final rename never
replaces a dataset that appeared meanwhile either (`fluids_bench.data.minari_export`), so
the claim is the early refusal and the rename the guarantee.
"""

from __future__ import annotations

import contextlib
import os
import socket
from collections.abc import Iterator
from pathlib import Path
from urllib.parse import quote

from fluids_bench.core.pool import pid_alive

CLAIMS_DIR = ".fluids-bench-claims"  # hidden: Minari skips dot-folders when listing


def claim_path(root: Path, dataset_id: str) -> Path:
    """The claim file of `dataset_id` under the datasets root (one flat name per id)."""
    return root / CLAIMS_DIR / quote(dataset_id, safe="")


def _owner(path: Path) -> tuple[str, int] | None:
    """`(host, pid)` written in a claim, or None when unreadable (being written, or gone)."""
    try:
        host, pid = path.read_text().split()
        return host, int(pid)
    except (OSError, ValueError):
        return None


def _create(path: Path) -> bool:
    for _ in range(3):
        path.parent.mkdir(parents=True, exist_ok=True)
        try:
            fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            break
        except FileExistsError:
            return False
        except FileNotFoundError:
            continue  # another run removed the empty claims folder just now: make it again
    else:
        raise FileNotFoundError(f"could not create the claim {path}")
    with os.fdopen(fd, "w") as handle:
        handle.write(f"{socket.gethostname()} {os.getpid()}\n")
    return True


@contextlib.contextmanager
def claim_dataset(root: Path, dataset_id: str) -> Iterator[Path]:
    """Hold the claim on `dataset_id` for the block; `FileExistsError` naming the process
    that holds it when another live run does."""
    path = claim_path(root, dataset_id)
    if not _create(path):
        owner = _owner(path)
        if owner is not None and owner[0] == socket.gethostname() and not pid_alive(owner[1]):
            path.unlink(missing_ok=True)  # its run was killed: take the claim over
        if not _create(path):
            who = "another run" if owner is None else f"process {owner[1]} on {owner[0]}"
            raise FileExistsError(
                f"dataset {dataset_id!r} is being written by {who} (claim {path}); "
                "wait for it to finish, or choose another dataset id"
            )
    try:
        yield path
    finally:
        path.unlink(missing_ok=True)
        with contextlib.suppress(OSError):
            path.parent.rmdir()  # only when no other run holds a claim
