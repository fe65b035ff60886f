"""The independent numpy reference implementation, as ``eodarm.reference``.

It lives in :mod:`eodarm.model.reference`; ``solve(..., backend="numpy")`` runs it.
"""

from eodarm.model.reference import *  # noqa: F403
from eodarm.model.reference import __all__ as __all__
