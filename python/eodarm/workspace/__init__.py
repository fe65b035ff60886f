"""The workspace layer: sweeps over the whole workspace and the maps computed from them.

Imports only from :mod:`eodarm.analysis`, :mod:`eodarm.data` and :mod:`eodarm.model`.
"""
