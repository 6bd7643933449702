"""``python -m vsw``: the vsw command line."""

from vsw.cli import main

raise SystemExit(main())
