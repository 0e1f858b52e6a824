from __future__ import annotations

import os

import pytest
from site_build import build_site


@pytest.fixture(scope="session")
def site(tmp_path_factory):
    base = tmp_path_factory.getbasetemp()
    # under xdist every worker's base temp (popen-gwN) sits in the session's own folder, which the
    # workers share; without xdist the base temp is that session folder itself, and its parent is
    # shared by every pytest session of the user (a site built there goes stale)
    if os.environ.get("PYTEST_XDIST_WORKER"):
        base = base.parent
    return build_site(base)
