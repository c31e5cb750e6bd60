"""How sure a relation is: the stereo depth error, whether it could flip the words, and a
calibrated probability that the relation is right.

Depth from a rectified stereo pair is Z = f·B/d; a disparity error σ_d (pixels) gives the
depth error σ_Z = Z²·σ_d/(f·B) (e.g. Gallup et al., "Variable baseline/resolution stereo",
CVPR 2008, eq. 1). Each object's centre moves along its viewing ray by that much; carried
through the angle of the vector between two centres (first order) this gives σ_θ, and the
relation "would change under that error" when its angular margin to the next direction's sector
(45° minus the deviation of the effective forces from the primary direction; for a compound
such as "front-left of", 45° minus the offset from the diagonal: it is wrong only outside the
quadrant it names) is less than ``HEDGE_Z`` × σ_θ. Then the words say "probably".

:func:`relation_confidence` maps three features — the rule base's self-assessment, the primary
direction's degree of truth and that margin in units of σ_θ — to the probability that the
primary direction is right, by a logistic model (Platt, "Probabilistic outputs for support
vector machines", 1999) fitted on generated TRAINING scenes (``benchmarks/bench_dialogue.py
--fit``, seed 7100) and checked on a different frozen set (seed 7001; reliability table and
expected calibration error in ``docs/dialogue.md``).

>>> round(depth_error(2.0, focal_px=554.0, baseline_m=0.12, sigma_px=0.5), 4)
0.0301
"""

from __future__ import annotations

import math

from scenespeak.spatial.dialogue import _fitted
from scenespeak.spatial.dialogue.scene import DialogueObject, DialogueRelation, DialogueScene
from scenespeak.spatial.dialogue.words import DIRECTION_ANGLE

__all__ = [
    "HEDGE_Z",
    "angle_sigma_deg",
    "depth_error",
    "features",
    "margin_z",
    "probability",
    "relation_confidence",
    "uncertain",
]

#: Margins below this many standard deviations of the angle make the words say "probably"
#: (one σ: the relation flips under the depth error with a probability above about 16 %).
HEDGE_Z = 1.0


def depth_error(z: float, *, focal_px: float, baseline_m: float, sigma_px: float) -> float:
    """Stereo depth error σ_Z = Z²·σ_d/(f·B), metres."""
    if focal_px <= 0 or baseline_m <= 0:
        return 0.0
    return z * z * sigma_px / (focal_px * baseline_m)


def _ray_sigma(obj: DialogueObject, scene: DialogueScene) -> tuple[float, float, float]:
    """(unit ray x, unit ray y, σ along it) of an object's centre on the plane."""
    x, y = obj.plane_centroid
    r = math.hypot(x, y) or 1.0
    z = max(abs(obj.depth), 1e-6)
    sz = depth_error(
        z, focal_px=scene.focal_px, baseline_m=scene.baseline_m, sigma_px=_fitted.SIGMA_PX
    )
    return (x / r, y / r, sz * r / z)


def angle_sigma_deg(a: DialogueObject, b: DialogueObject, scene: DialogueScene) -> float:
    """Standard deviation (degrees) of the angle of the vector from ``b``'s centre to ``a``'s
    under both objects' depth errors (first-order propagation)."""
    ax, ay = a.plane_centroid
    bx, by = b.plane_centroid
    vx, vy = ax - bx, ay - by
    n2 = vx * vx + vy * vy
    if n2 < 1e-12:
        return 180.0
    gx, gy = -vy / n2, vx / n2  # gradient of atan2(vy, vx) with respect to v
    var = 0.0
    for obj in (a, b):
        rx, ry, s = _ray_sigma(obj, scene)
        var += (s * (gx * rx + gy * ry)) ** 2
    return min(180.0, math.degrees(math.sqrt(var)))


def margin_z(rel: DialogueRelation, scene: DialogueScene) -> float:
    """The relation's angular margin to the next sector, in units of σ_θ (capped at 10)."""
    if rel.primary not in DIRECTION_ANGLE:
        return 10.0
    margin = 45.0 - abs(rel.deviation_deg)
    if rel.kind == "compound":  # "front-left of" is wrong only outside the quadrant it names
        margin = 45.0 - abs(45.0 - abs(rel.deviation_deg))
    sigma = angle_sigma_deg(scene.object(rel.argument), scene.object(rel.referent), scene)
    if sigma <= 1e-9:
        return 10.0
    return max(-10.0, min(10.0, margin / sigma))


def uncertain(rel: DialogueRelation, scene: DialogueScene) -> bool:
    """True when the depth error could change the relation's primary direction."""
    return rel.vertical is None and margin_z(rel, scene) < HEDGE_Z


def features(rel: DialogueRelation, scene: DialogueScene) -> tuple[float, float, float]:
    """(self-assessment, degree of the primary direction, margin in σ) of a relation."""
    degree = rel.degree(rel.primary) if rel.primary in DIRECTION_ANGLE else rel.confidence
    return (rel.confidence, degree, min(margin_z(rel, scene), 4.0))


def probability(x: tuple[float, float, float]) -> float:
    """The fitted logistic model: P(primary right | features)."""
    w = _fitted.WEIGHTS
    t = w[0] + w[1] * x[0] + w[2] * x[1] + w[3] * x[2]
    return 1.0 / (1.0 + math.exp(-t)) if t > -500 else 0.0


def relation_confidence(rel: DialogueRelation, scene: DialogueScene) -> float:
    """Calibrated probability (0-1) that the relation's primary direction is right."""
    if rel.vertical is not None:
        return max(rel.confidence, 0.9)
    return probability(features(rel, scene))
