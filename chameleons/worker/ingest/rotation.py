"""The head-rotation convention: :mod:`chameleons.arkit.rotation`, re-exported here (the
Python face tracker shares it and sits below the worker)."""

from chameleons.arkit.rotation import F64Array, rotation_matrix, yaw_pitch_roll, z_rotation

__all__ = ["F64Array", "rotation_matrix", "yaw_pitch_roll", "z_rotation"]
