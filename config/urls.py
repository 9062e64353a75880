from django.contrib import admin
from django.urls import include, path

# A database outage anywhere outside a view (e.g. saving the session) answers 503, not 500.
handler500 = "config.middleware.server_error"

urlpatterns = [
    path("admin/", admin.site.urls),
    path("precompute/", include("precompute.urls")),
    path("", include("studyapp.urls")),
]
