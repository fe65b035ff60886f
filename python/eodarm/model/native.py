"""The compiled core (``eodarm._core``), as every module of the package reaches it.

import-linter cannot look inside a compiled extension and reads an import of it as an import
of the package root, which imports every layer. Reaching the extension through this one
module keeps that to one edge, exempted by name in pyproject.toml.
"""

from eodarm._core import *  # noqa: F403
from eodarm._core import CoreError as CoreError
