"""Validation: simulation-based calibration of the Bayesian layer, calibration by regime on
virtual campaigns, and the corrected TI against a reference instrument (reference.py).

Rule: may import campaign, inference, data and physics; never workflow.
"""
