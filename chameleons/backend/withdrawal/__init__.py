"""Withdrawing a participant (all their data and files deleted) and rehearsal marking."""
