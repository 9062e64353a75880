from django.apps import AppConfig


class PrecomputeConfig(AppConfig):
    name = "precompute"
    verbose_name = "Precomputation jobs"
    default_auto_field = "django.db.models.BigAutoField"

    def ready(self):
        # connects worker_ready: a starting worker puts back the tasks of workers that died
        # and starts the watchdog for jobs whose messages the broker lost
        from . import recovery, watchdog  # noqa: F401, PLC0415  (AppConfig.ready: registers the signal handlers)
