"""Sim versus real: where residuals are structured, which candidate effects explain them.

The recipe (issue 8's research notes):

1. Noise from repeats: stations visited more than once (passes) give the repeatability and the
   lag-1 correlation of the deviations; residuals alone would not (they hold the very structure
   being looked for).
2. Localise: each residual against each driver with a permutation test that keeps the passes'
   own structure (whole-pass permutations for time-like drivers, per-pass cyclic shifts for
   position-like ones); a forward-minus-backward reversal profile; a periodogram against
   position; a CUSUM change point in time.
3. Select: forward selection among candidate effects by held-out (leave-one-pass-out, or
   blocked) cross-validation. A candidate is accepted only if it improves its axis's held-out
   RMS by a practical floor, its coefficients are well determined, and (for a periodic term) it
   helps along the whole travel. The floor is calibrated on null recordings (see
   ``benchmarks/discover.py``).
4. Structure no candidate explains is reported as ``nonsmooth`` with where it is, and modelled
   as a table of station corrections, not forced onto the nearest candidate.
5. Confounding: a candidate whose column the accepted model already nearly spans is reported
   with the experiment that would separate the two.

The modules: the candidate protocol (:mod:`.effect`), the linear layer (:mod:`.fit`), selection
and the table kept for what no candidate explains (:mod:`.select`), noise from repeats
(:mod:`.noise`), localisation (:mod:`.locate`), the ``nonsmooth`` table (:mod:`.nonsmooth`), the
harmonic-search kernel (:mod:`.harmonics`); and each instrument's candidates: :mod:`.stage`
(belt-stage, vision-stage), :mod:`.arm` (arm-cmm), :mod:`.probe_scanner`, :mod:`.stewart`. The
adapters that replay a recording with its twin and drive this engine live in each instrument's
folder (``calibench.scenarios.<instrument>.discovery``); ``calibench.scenarios.discover`` picks
one by the registry and holds what serves them all.

Residual arrays are in mm; drivers as in :mod:`.effect`.
"""
