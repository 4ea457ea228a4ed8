"""Correction: propagation of the posteriors to corrected TI, and LOS-level correction.

Rule: may import inference, data and physics; never campaign, validation or workflow.
"""
