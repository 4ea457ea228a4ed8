"""Physics: lidar scan geometry, platform motion, the VAD motion simulator and sigma_Z.

Rule: modules here depend only on NumPy, SciPy and each other; they import nothing
else of flidar_uq (checked by the import contract in ``pyproject.toml``).
"""
