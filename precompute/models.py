"""Precomputation jobs and their parts, for progress, failures and retries.

The chunk files on disk are the source of truth for a table build (a chunk
that exists is done); these rows are the bookkeeping the terminal progress
bar and the dashboard read.  One :class:`Part` row per finished unit of work
(a chunk of environments, a study condition, the test set), unique per job,
so a re-delivered task never counts twice.
"""
from __future__ import annotations

from django.db import models
from django.urls import reverse
from django.utils import timezone


class Job(models.Model):
    TABLE, STUDY = "table", "study"
    KINDS = [(TABLE, "trajectory table"), (STUDY, "study sequences")]
    PENDING, RUNNING, SUCCEEDED, FAILED = "pending", "running", "succeeded", "failed"
    STATUSES = [(PENDING, "pending"), (RUNNING, "running"), (SUCCEEDED, "succeeded"), (FAILED, "failed")]

    kind = models.CharField(max_length=10, choices=KINDS)
    params = models.JSONField(default=dict, help_text="Everything needed to (re)launch the job.")
    status = models.CharField(max_length=10, choices=STATUSES, default=PENDING, db_index=True)
    chunks_total = models.PositiveIntegerField(default=0, help_text="Units of work: chunks, or conditions + test set.")
    chunks_done = models.PositiveIntegerField(default=0)
    chunks_done_at_start = models.PositiveIntegerField(default=0, help_text="Already stored when last launched.")
    chunks_computed = models.PositiveIntegerField(default=0, help_text="Computed by this launch (not found stored).")
    trajectories_computed = models.BigIntegerField(default=0)
    attempts = models.PositiveIntegerField(default=0)
    created_at = models.DateTimeField(default=timezone.now)
    started_at = models.DateTimeField(null=True, blank=True, help_text="Last launch.")
    finished_at = models.DateTimeField(null=True, blank=True)
    error = models.TextField(blank=True)
    error_detail = models.TextField(blank=True, help_text="Traceback of the failure.")
    result_path = models.CharField(max_length=500, blank=True)
    result = models.JSONField(default=dict, blank=True)
    canvas_id = models.CharField(max_length=64, blank=True)
    heartbeat_at = models.DateTimeField(null=True, blank=True, help_text="Last time a task of it started.")
    alarm = models.TextField(blank=True, help_text="What the watchdog did: tasks lost by the broker (watchdog.py).")
    watchdog_relaunches = models.PositiveIntegerField(default=0, help_text="Relaunches by the watchdog since the "
                                                      "last launch by a person.")

    class Meta:
        ordering = ["-created_at"]

    def __str__(self):
        return f"job {self.pk} ({self.kind}: {self.label})"

    def get_absolute_url(self):
        return reverse("precompute:job", args=[self.pk])

    @property
    def label(self) -> str:
        if self.kind == self.TABLE:
            return f"table {self.params.get('preset', {}).get('name', '?')}"
        return f"study {self.params.get('slug', '?')}"

    @property
    def finished(self) -> bool:
        return self.status in (self.SUCCEEDED, self.FAILED)

    @property
    def fraction(self) -> float:
        return self.chunks_done / self.chunks_total if self.chunks_total else 0.0

    @property
    def percent(self) -> int:
        return int(100 * self.fraction)

    @property
    def elapsed(self) -> float | None:
        if not self.started_at:
            return None
        end = self.finished_at if self.finished and self.finished_at else timezone.now()
        return max((end - self.started_at).total_seconds(), 1e-9)

    @property
    def throughput(self) -> float | None:
        """Trajectories per second computed by the current launch (skipped chunks not counted)."""
        if not self.elapsed or not self.trajectories_computed:
            return None
        return self.trajectories_computed / self.elapsed

    @property
    def chunks_per_second(self) -> float | None:
        if not self.elapsed or not self.chunks_computed:
            return None
        return self.chunks_computed / self.elapsed

    @property
    def eta_seconds(self) -> float | None:
        rate = self.chunks_per_second
        if self.finished or not rate:
            return None
        return max(self.chunks_total - self.chunks_done, 0) / rate


class Part(models.Model):
    """One finished unit of a job: a chunk of a table, a condition or the test set of a study."""

    job = models.ForeignKey(Job, models.CASCADE, related_name="parts")
    key = models.CharField(max_length=100, help_text="Chunk content key, or condition name.")
    index = models.IntegerField(default=0)
    computed = models.BooleanField(default=True, help_text="False: it was already stored and was skipped.")
    seconds = models.FloatField(default=0.0)
    items = models.PositiveIntegerField(default=0, help_text="Trajectories computed (chunks).")
    worker = models.CharField(max_length=200, blank=True)
    result = models.JSONField(default=dict, blank=True)
    finished_at = models.DateTimeField(default=timezone.now)

    class Meta:
        ordering = ["job", "index"]
        constraints = [models.UniqueConstraint(fields=["job", "key"], name="one_part_per_key")]

    def __str__(self):
        return f"{self.job_id}/{self.key}"
