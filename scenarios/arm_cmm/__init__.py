"""Scenario ``arm-cmm``: its config and run (:mod:`.scenario`), its rerun layout (:mod:`.viewer`),
``calibench fit arm-cmm`` (:mod:`.fit`) and the arms as the estimators see them (:mod:`.arms`)."""
