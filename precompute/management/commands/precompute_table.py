"""Build a trajectory table with Celery workers: one task per chunk, then publish.

    python manage.py precompute_table --preset demo --wait
    python manage.py precompute_table --preset paper --out /shared/tables/paper

Sends the canvas and returns the job id (the job page shows progress), or
with --wait blocks with a progress bar and exits non-zero if the job fails.
Chunks already stored in --out are skipped, so running it again resumes.
"""
from __future__ import annotations

from pathlib import Path

from django.core.management.base import BaseCommand, CommandError

from precompute import jobs
from precompute.work import ChunkError
from teaching.api import PRESETS, SAMPLERS

from ._waiting import wait_for_job


def positive(name):
    def parse(value):
        try:
            v = int(value)
        except ValueError:
            raise CommandError(f"{name} must be a whole number, got {value!r}") from None
        if v <= 0:
            raise CommandError(f"{name} must be positive, got {v}")
        return v
    return parse


def resolve_preset(name, envs=None, thetas=None, seed=None, sampler=None, chunk_size=None, theta_star=None):
    """The named preset, with overrides (jobs.table_preset's rules, shared with the designer)."""
    try:
        return jobs.table_preset(name, envs=envs, thetas=thetas, seed=seed, sampler=sampler,
                                 theta_star=theta_star, chunk_size=chunk_size)
    except ValueError as exc:
        raise CommandError(str(exc)) from None


class Command(BaseCommand):
    help = "Build a trajectory table on Celery workers (one task per chunk of environments)."

    def add_arguments(self, parser):
        parser.add_argument("--preset", required=True, help=f"one of {', '.join(PRESETS)}")
        parser.add_argument("--out", help="table directory (default: $TABLES_DIR/<preset>); on a shared "
                                          "filesystem for several machines")
        parser.add_argument("--envs", type=positive("--envs"), help="override the number of environments")
        parser.add_argument("--thetas", type=positive("--thetas"), help="override the number of thetas")
        parser.add_argument("--seed", type=int, help="override the theta / environment sample seed")
        parser.add_argument("--sampler", help=f"override the theta sampler ({', '.join(SAMPLERS)})")
        parser.add_argument("--theta-star", help="the robot's objective, 5 negative weights: v1,v2,v3,v4,v5")
        parser.add_argument("--chunk-size", type=positive("--chunk-size"), help="environments per task")
        parser.add_argument("--queue", help="Celery queue (default: settings.PRECOMPUTE_QUEUE)")
        parser.add_argument("--wait", action="store_true", help="block with a progress bar until it finishes")
        parser.add_argument("--no-progress", action="store_true", help="with --wait: no progress bar")
        parser.add_argument("--timeout", type=float, help="with --wait: give up after this many seconds")

    def handle(self, *args, **opts):
        preset = resolve_preset(opts["preset"], opts["envs"], opts["thetas"], opts["seed"], opts["sampler"],
                                opts["chunk_size"], opts["theta_star"])
        out = Path(opts["out"] or jobs.tables_dir() / preset.name)
        try:
            job = jobs.create_table_job(preset, out, queue=opts["queue"])
        except (ChunkError, jobs.BrokerUnavailable) as exc:
            raise CommandError(str(exc)) from None
        self.stdout.write(f"job {job.pk}: {job.chunks_total} chunks of {preset.chunk_size} environments × "
                          f"{preset.n_thetas} thetas → {job.params['out']}  (page: /precompute/jobs/{job.pk}/)")
        if not opts["wait"]:
            return
        job = wait_for_job(self, job, opts)
        r = job.result
        self.stdout.write(f"table published at {r.get('path')}: {r.get('n_envs')} environments × "
                          f"{r.get('n_thetas')} thetas, hash {str(r.get('content_hash'))[:16]}; "
                          f"{job.chunks_computed} chunks computed, {job.chunks_total - job.chunks_computed} "
                          f"were already stored")
