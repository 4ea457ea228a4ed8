"""Data: the record contract, file I/O, QC filters, IMU statistics, bins and metrics.

Rule: may import :mod:`flidar_uq.physics`; nothing above it.
"""
