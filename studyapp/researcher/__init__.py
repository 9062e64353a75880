"""The researcher's side of a study: its spec checked once, the study built, piloted and watched on the dashboard."""
