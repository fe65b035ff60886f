"""The analysis layer: compare and fit, diagnose, calibrate, synthetic data, the investigation.

Imports only from :mod:`eodarm.data` and :mod:`eodarm.model`.
"""
