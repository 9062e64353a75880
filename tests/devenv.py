"""Loaded first (pytest.ini: -p tests.devenv), before pytest-django reads the settings: the suite runs
with the local development settings, as `make demo` does, unless the environment says otherwise.

Settings default to DEBUG off (a server started by hand is never in debug mode), which would need
a SECRET_KEY.  Subprocesses the tests start inherit this; tests of the production settings pass
DEBUG=0 and their own key explicitly (tests/studyapp/test_settings.py).
"""
import os

os.environ.setdefault("DEBUG", "1")
