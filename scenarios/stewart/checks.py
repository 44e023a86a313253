"""What makes a Stewart set-up workable: the config's checks, made before any simulation."""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

import numpy as np

from calibench.estimators.rotations import rotvec_to_matrix
from calibench.estimators.stewart.kinematics import leg_conditions
from calibench.scenarios.stewart import NAME
from calibench.scenes.stewart import LEG_STROKE_MM, PLATFORM_KG

if TYPE_CHECKING:  # the config's module imports this one
    from calibench.scenarios.stewart.scenario import StewartConfig

# the unknowns of one leg's one-step calibration: r (3), B (3), l
LEG_UNKNOWNS = 7

# What the config's checks hold the set-up to (see check_config):
# a 1-sigma geometric error over 10 % of the platform's size is not a calibration error;
MAX_ERROR_FRACTION = 0.1
# a leg's give under the load, of its length: beyond it the legs are springs;
MAX_GIVE_FRACTION = 0.01
# the poses' turn about each axis: beyond it the platform lies on its side;
MAX_ROTATION_DEG = 90.0
# the legs' Jacobian's condition (rotations over the platform's radius): beyond it, near-singular
MAX_CONDITION = 1000.0


@functools.lru_cache(maxsize=16)
def workspace(
    r: tuple, B: tuple, home_height_mm: float, translation_mm: float, rotation_deg: float
) -> tuple:
    """The legs at home (6,) and their Jacobian's condition there; the legs' shortest and longest
    and the largest condition over the poses' range (home +- translation along, +- rotation about
    each axis: the 3^6 corners and mid-points). Cached: a study's trials share their geometry, and
    the 729 poses cost a few milliseconds."""
    r_mm, B_mm = np.asarray(r, float).reshape(6, 3), np.asarray(B, float).reshape(6, 3)
    home_t = np.array([[0.0, 0.0, home_height_mm]])
    L_home, cond_home = leg_conditions(r_mm, B_mm, np.eye(3)[None], home_t)
    corners = np.array(np.meshgrid(*[[-1.0, 0.0, 1.0]] * 6)).reshape(6, -1).T  # (729, 6)
    R = rotvec_to_matrix(np.deg2rad(rotation_deg) * corners[:, 3:])
    L, cond = leg_conditions(r_mm, B_mm, R, home_t + translation_mm * corners[:, :3])
    return L_home[0], float(cond_home[0]), float(L.min()), float(L.max()), float(np.max(cond))


def check_config(c: StewartConfig) -> None:
    """What makes a Stewart set-up workable, checked before any simulation (BadInput, one line
    naming the key): enough poses for the legs' identification, a platform that is not singular
    and whose legs stay in their stroke over the poses, and errors that are errors."""
    from calibench.scenarios.config import bad, show
    from calibench.scenarios.report import BadInput

    g, t = c.geometry, c.truth
    need = LEG_UNKNOWNS + 1
    if c.n_poses < need:
        raise bad(
            f"{NAME}.n_poses",
            c.n_poses,
            f"at least {need}: each leg's one-step calibration solves {LEG_UNKNOWNS} unknowns "
            "(r, B, l) by "
            "least squares and scales their covariance by the residuals' variance, which needs "
            "one pose more",
        )
    if not c.rotation_deg <= MAX_ROTATION_DEG:
        raise bad(
            f"{NAME}.rotation_deg",
            c.rotation_deg,
            f"the poses turn by up to this about each axis: from 0 to {MAX_ROTATION_DEG:g} degrees",
        )
    # the platform at home: not singular, the legs within their stroke
    r, B = np.asarray(g.platform_hinges_mm, float), np.asarray(g.base_hinges_mm, float)
    size_p, size_b = (
        float(np.max(np.linalg.norm(r, axis=1))),
        float(np.max(np.linalg.norm(B, axis=1))),
    )
    L_home, cond_home, L_min, L_max, cond_max = workspace(
        tuple(r.ravel()),
        tuple(B.ravel()),
        float(g.home_height_mm),
        float(c.translation_mm),
        float(c.rotation_deg),
    )
    lo, hi = LEG_STROKE_MM
    if not np.all((L_home >= lo) & (L_home <= hi)):
        raise bad(
            f"{NAME}.geometry.home_height_mm",
            g.home_height_mm,
            f"at home the legs are {L_home.min():.4g} to {L_home.max():.4g} mm long: the legs' "
            f"stroke is {lo:g} to {hi:g} mm (the scene's slides)",
        )
    if not cond_home <= MAX_CONDITION:
        raise BadInput(
            f"config: {NAME}.geometry: platform_hinges_mm and base_hinges_mm leave the platform "
            f"singular at home (the legs' Jacobian has condition number {cond_home:.3g}, at most "
            f"{MAX_CONDITION:g}): "
            "six legs pin its six degrees of freedom only from hinges spread around platform and "
            f"base (now out to {size_p:.4g} mm and {size_b:.4g} mm from their centres)"
        )
    # the poses' range: home +- translation_mm, +- rotation_deg about each axis
    what = (
        f"the poses (home_height_mm = {show(g.home_height_mm)}, +- translation_mm = "
        f"{show(c.translation_mm)} "
        f"along and +- rotation_deg = {show(c.rotation_deg)} about each axis)"
    )
    if not lo <= L_min <= L_max <= hi:
        raise BadInput(
            f"config: {NAME}: {what} take the legs from {L_min:.4g} to {L_max:.4g} mm: their "
            "stroke is "
            f"{lo:g} to {hi:g} mm (the scene's slides); a smaller translation_mm or rotation_deg"
        )
    if not cond_max <= MAX_CONDITION:
        raise BadInput(
            f"config: {NAME}: {what} come near a singularity (the legs' Jacobian's condition "
            "number "
            f"{cond_max:.3g}, at most {MAX_CONDITION:g}); a smaller translation_mm or rotation_deg"
        )
    # the injected geometric errors: errors, not a different machine
    size = min(size_p, size_b)
    for key in ("hinge_error_mm", "length_error_mm", "station_offset_mm"):
        v = getattr(t, key)
        if not v <= MAX_ERROR_FRACTION * size:
            raise bad(
                f"{NAME}.truth.{key}",
                v,
                f"a 1-sigma geometric error is at most {MAX_ERROR_FRACTION:.0%} of the platform's "
                "size (its "
                f"hinges {size:g} mm from the centre): from 0 to {MAX_ERROR_FRACTION * size:g} mm",
            )
    # the legs' give under the load (the payload and the platform's weight, shared by six legs
    # leaning as they do at home): a small error, not a spring
    v = r + [0.0, 0.0, g.home_height_mm] - B
    lean = float(np.min(np.abs(v[:, 2]) / np.linalg.norm(v, axis=1)))
    force = abs(t.payload_n + 9.81 * PLATFORM_KG) / (6 * max(lean, 1e-3))
    give = np.abs(np.asarray(t.leg_compliance_um_per_n, float)) * force / 1000
    if not np.all(give <= MAX_GIVE_FRACTION * L_home):
        most = MAX_GIVE_FRACTION * float(L_home.min()) * 1000 / force
        raise bad(
            f"{NAME}.truth.leg_compliance_um_per_n",
            t.leg_compliance_um_per_n,
            f"a leg would give {give.max():.4g} mm under the load (payload_n = {t.payload_n:g} "
            "and the "
            f"platform's weight, about {force:.4g} N a leg): at most {MAX_GIVE_FRACTION:.0%} of "
            f"its length, compliance from 0 to {most:.3g} um/N",
        )
