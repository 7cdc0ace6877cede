"""The participant's phone: pages, JSON API and WebSocket, reachable only by the session's
unguessable link. Nothing here may carry a condition name (see ``view.py``)."""
