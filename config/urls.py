from django.contrib import admin
from django.urls import include, path

urlpatterns = [
    path("admin/", admin.site.urls),
    path("precompute/", include("precompute.urls")),
    path("", include("studyapp.urls")),
]
