from django.contrib import admin
from django.contrib.auth import views as auth_views
from django.urls import include, path

# A database outage anywhere outside a view (e.g. saving the session) answers 503, not 500.
handler500 = "config.middleware.server_error"

urlpatterns = [
    path("admin/", admin.site.urls),
    # the researchers' own login (throttled by django-axes) and logout, not the admin's
    path("login/", auth_views.LoginView.as_view(redirect_authenticated_user=False), name="login"),
    path("logout/", auth_views.LogoutView.as_view(), name="logout"),
    path("precompute/", include("precompute.urls")),
    path("", include("studyapp.urls")),
]
