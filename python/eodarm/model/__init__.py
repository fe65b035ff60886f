"""The model layer: arm files, effects, the solvers (compiled core and numpy reference), FE.

Imports nothing from the layers above it (data, analysis, workspace, viz, cli).
"""
