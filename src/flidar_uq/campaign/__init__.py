"""Virtual campaigns with ground truth: scenarios, physics mode, statistical mode.

Rule: may import physics, data and (statistical mode only: records drawn from the
Bayesian model itself) inference; never correction, validation or workflow.
"""
