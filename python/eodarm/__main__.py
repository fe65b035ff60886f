"""``python -m eodarm``: the command line."""

from eodarm.cli import main

raise SystemExit(main())
