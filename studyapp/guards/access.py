"""Who may see researcher pages: staff accounts (manage.py create_researcher), through the
researchers' own login page (config/urls.py), never the admin's."""
from functools import partial

from django.contrib.admin.views.decorators import staff_member_required

#: A view decorator: staff members pass; anyone else is sent to the researcher login page.
researcher_required = partial(staff_member_required, login_url="login")
