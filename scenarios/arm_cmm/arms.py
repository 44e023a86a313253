"""One description of an arm, and the estimators' view of it derived from it.

Design. The arm's description (:class:`~calibench.scenes.arm_cmm.ArmDescription`, read from
an ARM.toml) is the single source of an arm's numbers. Two rooms need them, and neither may see
the other's code:

- the simulation builds its MuJoCo twin from the description itself (``sim`` never imports the
  estimators: the twin's kinematics stay independent of the model under test, so a test that
  compares the two compares two implementations);
- the estimators run on real recordings without scenes or sim, so they keep their own type,
  :class:`~calibench.estimators.arm.kinematics.Chain`, whose fields are a subset of the
  description's, under the same names and in the same units.

:func:`chain_of` is the one place the second form is made from the first, and it is generic:
for every field of ``Chain`` it takes the description's field of that name (a tuple becomes a
float array, anything else passes as it is), so no field is copied by hand. The description's
fields the estimators do not take are named in :data:`NOT_IN_CHAIN`, each with its reason;
``chain_of`` refuses a description with a field that is in neither (a ``TypeError`` naming it),
so a field added to the description cannot be silently left out of the chain, and a field added
to the chain but not to the description fails just as loudly (the description has no such
attribute). ``tests/scenarios/test_arm_cmm.py`` checks both, and that the two forms agree.

The methods both types have (``n_joints``, ``has_masses``, ``nominal``) are deliberately two:
the twin reads its nominal table from the description, the model from its chain, and a fault in
the model's (``tests/sabotage.py``, ``arm_dh_*``) must not reach the twin.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.arm.kinematics import Chain
from calibench.scenes.arm_cmm import ArmDescription, load_arm  # noqa: F401  (re-exported)

# The description's fields that the estimators' chain does not take, and why.
NOT_IN_CHAIN = {
    "name": "the arm's name, for reports and messages",
    "range_rad": "the postures a simulation draws from; a fit takes the postures it is given",
    "source": "the file the description was read from",
    "cable_stiffness_nm_per_rad": "the twin's cables; a fit estimates their compliance itself",
}


def _chain_fields(description_type: type) -> tuple[str, ...]:
    """Chain's field names, once checked against ``description_type``'s: every field of the
    description is one of the chain's or named in :data:`NOT_IN_CHAIN`."""
    described = {f.name for f in dataclasses.fields(description_type)}
    modelled = tuple(f.name for f in dataclasses.fields(Chain))
    forgotten = described - set(modelled) - set(NOT_IN_CHAIN)
    if forgotten:
        raise TypeError(
            f"{description_type.__name__} has field(s) {', '.join(sorted(forgotten))} that the "
            "estimators' Chain does not take: add them to Chain (same name, same unit) or to "
            "NOT_IN_CHAIN with the reason the estimators do without them"
        )
    return modelled


def chain_of(arm: ArmDescription) -> Chain:
    """The estimators' view of an arm description: each of :class:`Chain`'s fields taken from the
    description's field of the same name (tuples as float arrays).

    Parameters
    ----------
    arm : the description (nominal kinematics mm and rad, masses kg, centres of mass (N, 3) mm,
        tool point (3,) mm, gravity (3,) m/s^2).

    Returns
    -------
    Chain

    Raises
    ------
    TypeError
        When the description has a field the chain neither takes nor is said to do without
        (:data:`NOT_IN_CHAIN`).
    """
    return Chain(**{k: _as_array(getattr(arm, k)) for k in _chain_fields(type(arm))})


def _as_array(value):
    """A description's tuple as a float array; None, text and numbers as they are."""
    return np.array(value, float) if isinstance(value, tuple) else value
