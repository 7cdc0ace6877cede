"""The server-enforced session state machine and the wizard's JSON API and live feed."""
