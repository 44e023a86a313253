"""Scenario ``stewart``: its config and run (:mod:`.scenario`) and its rerun layout
(:mod:`.viewer`)."""
