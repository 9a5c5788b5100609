"""The bad-input table, one module per area (``ROWS``); see ``tests/badinput.py``."""
