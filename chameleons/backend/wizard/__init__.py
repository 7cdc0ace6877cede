"""The wizard console: its page, the prompt API (play/stop with latencies) and its live feed."""
