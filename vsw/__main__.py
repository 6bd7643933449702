"""``python -m vsw``: the vsw command line."""

from vsw.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
