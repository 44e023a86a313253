"""The one identification core: a problem protocol (:mod:`.problem`), the identifiable basis
(:mod:`.basis`), one Levenberg-Marquardt solver with a status and a trace (:mod:`.solver`) and the
covariance of its estimate (:mod:`.covariance`). The arm's problems and the Stewart platform's
joint adjustment use it.
"""
