"""The PI dashboard: study progress, live balance, sessions with data-quality flags."""
