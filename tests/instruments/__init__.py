"""Instruments that exist only in the tests: the proof that an instrument is its own folder.

An instrument of calibench is its modules and one line in the registry
(:class:`calibench.scenarios.instrument.Instrument`, :func:`calibench.scenarios.registry.register`).
The built-in ones live in ``calibench.scenarios``; the ones here live in the tests and register
themselves when their package is imported:

- :mod:`tests.instruments.rail`: a one-axis stage (a screw's nut pulling a carriage through a
  belt, the carriage's friction against the world) with a scale error and lost motion. Its
  scenario (``run``, ``prior``: ``calibench run`` and ``montecarlo``), its recording format and its
  discovery adapter (``discover``, the suites) are its own modules and nothing else.

The seam they prove: importing the package registers the instrument in this process; a spawned
process (a study's worker) sees it when its environment names the package in
``CALIBENCH_INSTRUMENTS`` and the repository root in ``PYTHONPATH`` (the workers run with
``PYTHONSAFEPATH=1``). tests/scenarios/test_rail_instrument.py drives it through the command line.
"""
