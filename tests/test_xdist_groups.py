"""`make test` relies on pytest-xdist's `--dist loadgroup`: the tests of one `xdist_group` run on one worker (the two
Ray files, so that one Ray runs at a time; tests sharing a costly fixture, so that it is made once). pytest 9.2
with pytest-xdist 3.8 silently ignores the groups (pytest-xdist issue #1386), so constraints.txt pins a pytest that
applies them; this test fails where they are not applied."""

from __future__ import annotations

import pytest

pytestmark = pytest.mark.xdist_group("xdist_check")


def test_xdist_groups_are_applied(request) -> None:
    if not getattr(request.config.option, "loadgroup", False):
        pytest.skip("runs only on an xdist worker under --dist loadgroup (as `make test` runs)")
    assert request.node.nodeid.endswith("@xdist_check"), (
        f"pytest {pytest.__version__} with this pytest-xdist ignores xdist_group under --dist loadgroup (pytest-xdist "
        f"issue #1386): install the pinned versions of constraints.txt")
