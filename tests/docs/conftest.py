from __future__ import annotations

import pytest
from site_build import build_site


@pytest.fixture(scope="session")
def site(tmp_path_factory):
    # the parent of the per-worker base temp is shared by every xdist worker of the session
    return build_site(tmp_path_factory.getbasetemp().parent)
