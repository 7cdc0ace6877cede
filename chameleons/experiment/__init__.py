"""The experiment core: the study as data, counterbalancing, the suggestion policy, statistics.

Pure domain code. It imports nothing from ``chameleons.backend`` or ``chameleons.worker``
and does no I/O beyond reading a study's YAML file.
"""
