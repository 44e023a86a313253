"""calibench: a simulation-first test bench for calibrating measuring machines.

The four rooms install as subpackages (the folders stay at the repository's top level):
``calibench.scenes`` (what the machines are), ``calibench.sim`` (the as-built world and its
sensors), ``calibench.estimators`` (pure algorithms) and ``calibench.scenarios`` (experiments,
reports, the command line).
"""

__version__ = "0.2.0"
