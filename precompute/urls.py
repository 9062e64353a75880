from django.urls import path

from . import views

app_name = "precompute"
urlpatterns = [
    path("", views.job_list, name="jobs"),
    path("design/", views.design, name="design"),
    path("design/table/", views.design_table, name="design_table"),
    path("design/supply.json", views.design_supply, name="design_supply"),
    path("jobs/<int:pk>/", views.job_detail, name="job"),
    path("jobs/<int:pk>/status.json", views.job_status, name="job_status"),
    path("jobs/<int:pk>/retry/", views.job_retry, name="job_retry"),
]
