from django.apps import AppConfig


class StudyappConfig(AppConfig):
    name = "studyapp"
    verbose_name = "Online study"
    default_auto_field = "django.db.models.BigAutoField"
