"""Experiments: wire scene, sim and estimators, compare Estimate with Truth, report, CLI.

Runs are reproducible to the last bit from their seed: OpenCV's multithreaded reductions
(calibration, PnP) are not, so a scenario runs with OpenCV single-threaded
(:meth:`calibench.scenarios.registry.Scenario.execute`), and gives the thread count back after.
Importing this package changes nothing global.
"""
