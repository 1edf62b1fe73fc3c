"""`python -m app.cli ...`: the `humanoid` command."""

from app.cli.main import main

raise SystemExit(main())
