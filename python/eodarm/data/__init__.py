"""The data layer: measurement files and the bundled data sets (their files live here too).

Imports only from :mod:`eodarm.model`.
"""
