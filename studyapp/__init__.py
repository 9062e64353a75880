"""The web app for between-subjects online studies, in rooms by what a newcomer looks for.

From the ground up (a room imports only the floors below it; tests/test_house.py keeps it so):

* the ground floor, shared by every room: ``models``, a participant's ``status``, the names of
  ``conditions``, the robot's texts (``i18n``) and a page's ``language``, its ``scenes`` and ``trajectories``;
* ``guards``: who may see researcher pages, rate limits, size caps, login lockout and CSV injection;
* ``participant``: arrival and assignment, each step's page (``participant.pages``), answers and endings;
* ``data``: the CSV exports and their dictionary, and participants' rights to their data;
* ``analysis``: the statistics, figures and report of a study's answers, and simulated participants;
* ``researcher``: a study spec checked once, the study built, piloted and watched on the dashboard;
* the entry points: ``urls``, ``admin`` and the management commands.
"""
