"""Validation of the Bayesian layer: simulation-based calibration.

Rule: may import campaign, inference, data and physics; never workflow.
"""
