"""``python -m setupfix`` runs the command line."""

from setupfix.cli import main

raise SystemExit(main())
