"""The ``tognet`` console script: a Ctrl-C while the command line's modules are still loading ends the
command with one line too (:func:`tognet.cli.main` handles it from then on)."""

from __future__ import annotations

import sys


def run() -> None:
    """Load the command line and run it."""
    try:
        from tognet.cli import main
    except KeyboardInterrupt:
        print("interrupted (SIGINT) while starting; nothing was written", file=sys.stderr)
        raise SystemExit(130) from None
    main()
