"""What a study's data leaves as: CSV exports with their data dictionary, and participants' rights to their data."""
