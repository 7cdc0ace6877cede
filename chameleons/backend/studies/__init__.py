"""Studies (config snapshot + hash), their counterbalancing plan rows, and participants."""
