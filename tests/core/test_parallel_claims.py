"""One writer per dataset id: exclusive claims, released after, taken over from dead runs."""

from __future__ import annotations

import os
import socket
import subprocess
import sys

import pytest

from fluids_bench.core.parallel import claim_dataset, claim_path


def test_a_claim_is_exclusive_and_released(tmp_path):
    with claim_dataset(tmp_path, "ns/name-v0") as path:
        assert path.read_text().split() == [socket.gethostname(), str(os.getpid())]
        with pytest.raises(FileExistsError, match=f"process {os.getpid()} on "):
            with claim_dataset(tmp_path, "ns/name-v0"):
                pass
        with claim_dataset(tmp_path, "ns/other-v0"):  # another id is free
            pass
        assert path.exists()  # the refused attempt left the holder's claim alone
    assert not path.exists() and not path.parent.exists()


def test_the_claim_of_a_killed_run_is_taken_over(tmp_path):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()  # reaped: its pid names no process now
    path = claim_path(tmp_path, "ns/name-v0")
    path.parent.mkdir()
    path.write_text(f"{socket.gethostname()} {dead.pid}\n")
    with claim_dataset(tmp_path, "ns/name-v0"):
        assert path.read_text().split()[1] == str(os.getpid())
