"""The visualisation layer: figures and the HTML report (matplotlib, imported lazily).

Imports only from the layers below it; nothing here parses command lines.
"""
