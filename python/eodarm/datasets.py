"""The bundled data sets, as ``eodarm.datasets``: ``eodarm.datasets.load("seed2022")``.

They live in :mod:`eodarm.data.datasets` (the arm, the measurements and the paper's tables of
each; ``eodarm datasets export NAME DIR`` copies the files).
"""

from eodarm.data.datasets import *  # noqa: F403
from eodarm.data.datasets import __all__ as __all__
