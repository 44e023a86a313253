"""The bad-input corpus, one module of cases per verb (tests/test_bad_input.py runs them all)."""
