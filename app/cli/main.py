"""The `humanoid` command's entry point, kept free of imports.

Processes the app starts (the robot, the 3D views) are spawned: each runs the main script again to find its
functions, and the installed `humanoid` script imports this module. Importing the commands here cost each of them
~1.4 s of start-up (the settings, the database, TLS) they never use.
"""

from __future__ import annotations

import sys


def main(argv: list[str] | None = None) -> int:
    """Parse the command line and run the command."""
    from app.cli.commands import main as run

    return run(argv)


if __name__ == "__main__":
    sys.exit(main())
