"""The bad-specification fixtures are inputs for tests (some raise at import by design):
pytest's doctest collection must not import them."""

collect_ignore_glob = ["bad_spec_*.py"]
