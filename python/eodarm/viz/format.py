"""The one formatter of numbers and names, under the name the figures and the commands know.

It lives in :mod:`eodarm.text`, below every layer, so that the short reprs of the model's and
the analysis' objects (:mod:`eodarm.reprs`) read their numbers as the tables, lines and
pages do.
"""

from eodarm.text import *  # noqa: F403
from eodarm.text import __all__ as __all__
