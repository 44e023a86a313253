"""The null calibration's bookkeeping (scenarios/discover/nulls.py) on a real null recording:
nothing is concealed in it, so at the house floor (calibrated on such nulls) discover claims
nothing, and the rate is reported per scenario and floor."""

from concurrent.futures import ThreadPoolExecutor

from calibench.estimators.discovery.select import FLOOR
from calibench.scenarios.discover.nulls import null_claim_rates


def test_a_null_recording_gets_no_claim_at_the_house_floor():
    with ThreadPoolExecutor(1) as pool:
        rates = null_claim_rates({"belt-stage": (FLOOR,)}, 1, pool)
    assert rates == {"belt-stage": {FLOOR: 0.0}}
