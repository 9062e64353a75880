"""Loaded first (pytest.ini: -p tests.devenv), before pytest-django reads the settings: the suite runs
with the local development settings, as `make demo` does, unless the environment says otherwise.

Settings default to DEBUG off (a server started by hand is never in debug mode), which would need
a SECRET_KEY.  Subprocesses the tests start inherit this; tests of the production settings pass
DEBUG=0 and their own key explicitly (tests/studyapp/test_settings.py).
"""
import os

os.environ.setdefault("DEBUG", "1")

# Under pytest-xdist each worker gets its own var/ (SQLite files, the filesystem broker's folders,
# tables): two workers sharing one broker folder would run each other's tasks.
_worker = os.environ.get("PYTEST_XDIST_WORKER")
if _worker:
    os.environ.setdefault("VAR_DIR", os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                                  "var", f"test-{_worker}"))
