"""The opentmcl package's own suite. It runs against the installed wheel: the checkout must not be on
sys.path (scripts/python-package-tests.sh runs it from a copy of this folder)."""

import opentmcl
import pytest


def pytest_report_header(config):
    return f"opentmcl {opentmcl.__version__} from {opentmcl.__file__}"


@pytest.fixture(scope="session", autouse=True)
def installed_package():
    # The suite is meant for the installed wheel, not for sources beside it.
    assert "site-packages" in opentmcl.__file__, opentmcl.__file__
