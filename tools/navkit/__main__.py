"""`python -m navkit` runs the CLI."""

from navkit.cli import main

raise SystemExit(main())
