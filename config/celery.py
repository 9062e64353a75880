"""The project's Celery app (standard Django layout).

Broker and result backend come from settings (CELERY_* names); the default
broker is kombu's filesystem transport under var/broker, so no server is
needed to run tasks locally.
"""
import os

from celery import Celery

os.environ.setdefault("DJANGO_SETTINGS_MODULE", "config.settings")

app = Celery("config")
app.config_from_object("django.conf:settings", namespace="CELERY")
app.autodiscover_tasks()
