"""Uncertainty as metrologists state it: the GUM framework's law of propagation (:mod:`.gum`,
JCGM 100), the adaptive Monte Carlo procedure of JCGM 101 7.9 over a task's many output
quantities at once (:mod:`.adaptive`), the coverage intervals of Monte Carlo trials
(:mod:`.coverage`, JCGM 101 7.7), and the validation of the one by the other (JCGM 101 8).
"""
