"""Shared by every test folder: pytest puts this folder on ``sys.path`` when it loads this file,
so test modules anywhere under ``tests/`` can ``from exact_compare import exactly_equal``."""
