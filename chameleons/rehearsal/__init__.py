"""Rehearsals: scripted wizards and participants that run whole sessions through the
server's public HTTP and WebSocket interfaces (``chameleons rehearse``)."""
