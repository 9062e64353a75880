from django.apps import AppConfig


class PrecomputeConfig(AppConfig):
    name = "precompute"
    verbose_name = "Precomputation jobs"
    default_auto_field = "django.db.models.BigAutoField"
