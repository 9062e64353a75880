"""Putting back the tasks of a worker that died, as soon as a worker starts (Redis broker).

Precompute tasks are ``acks_late``: Redis keeps each delivered message in its ``unacked`` hash
until the task finishes.  When a whole worker dies (SIGKILL of its process group, the
out-of-memory killer, a machine lost), nobody acknowledges or rejects its message, and kombu
hands it out again only after the visibility timeout (an hour: longer than any task, or a
running task would be handed to a second worker).  So a job would wait an hour.

Instead, every worker, once it is ready, asks every live worker which tasks it holds (Celery's
``inspect``: active, reserved, scheduled) and puts back on its queue every unacknowledged
message that was delivered before the question and that no live worker holds: those belong
to workers that are gone.  Under scripts/serve.sh supervisord restarts a killed worker within
seconds, so the job resumes then.

A live worker that does not answer within INSPECT_TIMEOUT seconds (its main process blocked)
would have its message handed out twice; the work is idempotent (content-addressed chunk
files, a study condition stored once), so that costs time, never correctness.
"""
from __future__ import annotations

import json
import logging
import threading
import time

from celery.signals import worker_ready

log = logging.getLogger(__name__)

INSPECT_TIMEOUT = 2.0  # seconds every live worker has to say which tasks it holds
SETTLE = 1.0  # seconds after worker_ready before asking: this worker's own event loop is running


def uses_redis(app) -> bool:
    return str(app.conf.broker_url or "").startswith(("redis://", "rediss://", "sentinel://"))


def live_task_ids(app, timeout: float = INSPECT_TIMEOUT) -> set[str]:
    """Ids of every task some live worker is running, has reserved or has scheduled."""
    inspect = app.control.inspect(timeout=timeout)
    ids: set[str] = set()
    for reply in (inspect.active(), inspect.reserved(), inspect.scheduled()):
        for tasks in (reply or {}).values():
            for task in tasks:
                request = task.get("request", task)  # scheduled() wraps the request
                if request.get("id"):
                    ids.add(request["id"])
    return ids


def restore_orphans(app, *, timeout: float = INSPECT_TIMEOUT) -> list[str]:
    """Put back every unacknowledged message no live worker holds; returns their task ids.

    Only messages delivered before the live workers were asked are considered: a message
    delivered since may belong to a worker whose answer did not list it yet.
    """
    if not uses_redis(app):
        return []  # the filesystem broker keeps no unacknowledged messages to restore
    asked_at = time.time()
    live = live_task_ids(app, timeout)
    restored = []
    with app.connection_for_write() as conn:
        channel = conn.default_channel
        client = channel.client
        for tag in client.zrangebyscore(channel.unacked_index_key, 0, asked_at):
            raw = client.hget(channel.unacked_key, tag)
            if raw is None:
                continue  # acknowledged meanwhile
            message = json.loads(raw)[0]
            task_id = message.get("headers", {}).get("id") or message.get("properties", {}).get("correlation_id")
            if task_id in live:
                continue
            # a transaction on the unacked hash: two workers starting together restore it once
            channel.qos.restore_by_tag(tag, client)
            restored.append(task_id)
    return restored


def _restore_in_background(app) -> None:
    def run():
        time.sleep(SETTLE)
        try:
            restored = restore_orphans(app)
        except Exception:  # never take the worker down over this: the visibility timeout remains
            log.exception("precompute: could not look for tasks of dead workers")
            return
        if restored:
            log.warning("precompute: put back %d task(s) left by a worker that died: %s",
                        len(restored), ", ".join(restored))

    threading.Thread(target=run, name="restore-orphans", daemon=True).start()


@worker_ready.connect
def _on_worker_ready(sender=None, **_):
    app = getattr(sender, "app", None)
    if app is not None:
        _restore_in_background(app)
