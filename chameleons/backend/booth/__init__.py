"""The booth follows the session: the robot's condition and face, the worker's recordings
and outages in the timeline, driven by committed session events (see :mod:`.flows`)."""
