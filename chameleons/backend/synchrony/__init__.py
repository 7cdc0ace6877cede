"""Synchrony of the recorded faces per interaction (issue 32): computed in the background
when a recording stops, stored, exported, plotted on the session page."""
