"""Celery workers that precompute trajectory tables and teaching sequences.

Pieces: :mod:`precompute.jobs` (launching canvases, pure of views),
:mod:`precompute.tasks` (the Celery tasks), :mod:`precompute.models` (Job and
its per-chunk records, for progress and the dashboard), management commands
``precompute_table`` and ``build_study``, and the job pages in
:mod:`precompute.views`.  See docs/scaling.md.
"""
