"""The commands and their one-line help: what ``eodarm --help`` lists without importing them."""

import re

__all__ = ["HELP", "NEGATIVE_VALUE"]

#: One line per command, in the order of ``eodarm --help``; each command is the module of that
#: name in this package, with ``add_parser(sub)`` and ``run(args)``.
HELP = {
    "solve": "loaded minus unloaded pose, actuator forces and deflections for given poses",
    "compare": "model vs measurements: residuals, RMS, chi2, worst rows, outliers",
    "diagnose": "rank every candidate effect; find the missing set",
    "fit": "fit the parameters of the added effects",
    "records": "steady states of raw records (a campaign) -> a measurement file with errors",
    "synth": "write a synthetic measurement file (the model with hidden effects + noise)",
    "plan": "choose the configurations to measure so that the missing effect can be named",
    "sweep": "solve a whole grid of poses × payloads; write NetCDF/Zarr and the four maps",
    "report": "the whole story as one HTML report (default: the bundled seed data)",
    "datasets": "bundled data sets: list, export",
    "compensate": "the angles to command so that the payload does not move the measure point",
}

#: What the parser takes for a value rather than an option: a negative number, and a list or a
#: range that starts with one (``--alpha -5,10,0``, ``--alpha3 -20:20:21``).
NEGATIVE_VALUE = re.compile(r"^-\d+$|^-\d*\.\d+$|^-[\d.]+(:[-\d.]+)+$|^-[\d.]+[,;]")
