from django.contrib import admin
from django.contrib.auth import views as auth_views
from django.templatetags.static import static
from django.urls import include, path
from django.views.generic import RedirectView

# A database outage anywhere outside a view (e.g. saving the session) answers 503, not 500.
handler500 = "config.middleware.server_error"

urlpatterns = [
    path("admin/", admin.site.urls),
    # browsers ask for /favicon.ico on a first visit whatever the page's <link rel="icon"> says
    path("favicon.ico", RedirectView.as_view(url=static("studyapp/favicon.svg"), permanent=True)),
    # the researchers' own login (throttled by django-axes) and logout, not the admin's
    path("login/", auth_views.LoginView.as_view(redirect_authenticated_user=False), name="login"),
    path("logout/", auth_views.LogoutView.as_view(), name="logout"),
    path("precompute/", include("precompute.urls")),
    path("", include("studyapp.urls")),
]
