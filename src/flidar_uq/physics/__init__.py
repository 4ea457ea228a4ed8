"""Physics: lidar scan geometry, platform motion, the VAD motion simulator and sigma_Z.

Rule: modules here depend on NumPy, SciPy, each other and the package's utilities
(``seeding``, ``threads``, ``compiled``); they import no other layer of flidar_uq
(checked by the import contract in ``pyproject.toml``).
"""
