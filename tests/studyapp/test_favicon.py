"""Every page names its icon, and a browser's own request for /favicon.ico finds it: no 404 in the
server's log on a participant's first visit."""
from django.contrib.staticfiles import finders


def test_the_icon_is_named_and_found(client, db):
    page = client.get("/").content.decode()
    assert '<link rel="icon" href="/static/studyapp/favicon.svg" type="image/svg+xml">' in page
    r = client.get("/favicon.ico")
    assert r.status_code == 301 and r["Location"] == "/static/studyapp/favicon.svg"
    assert finders.find("studyapp/favicon.svg")
