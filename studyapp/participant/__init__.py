"""The participant's side of a study: arrival and assignment, each step's page, answers and how a study ends."""
