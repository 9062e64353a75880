"""A restarted Celery worker is back quickly: its main process imports Celery, Django and the
bookkeeping only, never the numeric stack (NumPy's friends Numba and SciPy, the teaching core),
which a pool process imports at its first task (precompute/steps.py).  That halves a worker's
start (bench/worker_boot.py), which is what brings a killed worker back within the 10-s bar
on a busy machine (tests/load/test_supervision.py)."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from precompute import steps, tasks

ROOT = Path(__file__).resolve().parents[2]

# What `celery -A config worker` imports before it is ready, as config/supervisord.conf runs it
# (CELERY_SKIP_CHECKS: Django's system checks, which load every view, ran once in serve.sh's
# migrate): Django's apps (their ready() hooks: the watchdog, the recovery of dead workers'
# tasks) and every tasks module Celery discovers.
BOOT = """
import json, sys
import django
django.setup()
from config.celery import app
app.loader.import_default_modules()
heavy = ("teaching", "numba", "llvmlite", "scipy", "matplotlib", "pandas", "statsmodels", "precompute.steps")
print(json.dumps(sorted(m for m in sys.modules if m.startswith(heavy))))
"""


def test_the_workers_main_process_imports_no_numeric_stack_at_boot(tmp_path):
    env = {k: v for k, v in os.environ.items() if not k.startswith(("DJANGO_", "DATABASE_"))}
    env.update(DJANGO_SETTINGS_MODULE="config.settings", DEBUG="1", CELERY_SKIP_CHECKS="1", VAR_DIR=str(tmp_path),
               PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-c", BOOT], cwd=ROOT, env=env, capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr[-3000:]
    loaded = json.loads(out.stdout.strip().splitlines()[-1])
    assert loaded == [], f"the worker's boot imports {loaded[:12]}: import them in precompute/steps.py instead"


def test_every_task_still_finds_its_work():
    """The tasks reach their work through steps(): each name they use exists there."""
    assert tasks.steps() is steps
    for name in ("compute_chunk", "publish", "select_condition", "finish_study"):
        assert callable(getattr(steps, name)), name
