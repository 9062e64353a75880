from django.urls import path, re_path

from . import language
from .analysis import views as analysis_views
from .participant import views
from .researcher import dashboard, stimuli

urlpatterns = [
    path("", views.home, name="home"),
    path("s/<slug:slug>/", views.entry, name="entry"),
    path("s/<slug:slug>/p/<str:token>/", views.step, name="step"),
    path("s/<slug:slug>/jsi18n.js", language.javascript_catalog, name="jsi18n"),
    path("s/<slug:slug>/p/<str:token>/<int:step_index>/", views.answer, name="answer"),
    path("s/<slug:slug>/p/<str:token>/media/<str:name>", views.media, name="participant_media"),
    path("dashboard/", dashboard.index, name="dashboard"),
    path("dashboard/<slug:slug>/", dashboard.detail, name="dashboard_study"),
    path("dashboard/<slug:slug>/progress/", dashboard.progress, name="dashboard_progress"),
    path("dashboard/<slug:slug>/toggle/", dashboard.toggle, name="dashboard_toggle"),
    path("dashboard/<slug:slug>/preview/<int:condition_id>/", dashboard.preview, name="dashboard_preview"),
    path("dashboard/<slug:slug>/analysis/", analysis_views.report, name="dashboard_analysis"),
    path("dashboard/<slug:slug>/analysis/models/", analysis_views.models, name="dashboard_models"),
    path("dashboard/<slug:slug>/analysis/models.csv", analysis_views.models_csv, name="dashboard_models_csv"),
    path("dashboard/<slug:slug>/stimuli/", stimuli.stimuli, name="dashboard_stimuli"),
    path("dashboard/<slug:slug>/media/<str:name>", stimuli.media, name="dashboard_media"),
    path("dashboard/<slug:slug>/erase/", dashboard.erase, name="dashboard_erase"),
    path("dashboard/<slug:slug>/returned/", dashboard.mark_returned, name="dashboard_returned"),
    re_path(r"^dashboard/(?P<slug>[-\w]+)/export/(?P<kind>long|wide|dictionary|bonuses-prolific|bonuses-mturk)\.csv$",
            dashboard.export, name="dashboard_export"),
]
