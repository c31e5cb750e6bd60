"""The rule base's thresholds: every value, the test that pins it and why."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["DEFAULT_THRESHOLDS", "Thresholds"]


@dataclass(frozen=True)
class Thresholds:
    """Every threshold of the rule base: value, the test that pins it, and why.

    Degrees of truth are in [0, 1]; a single force spike ``δ`` degrees off a direction scores
    ``1 − δ/90`` for it and ``δ/90`` for the neighbour it leans to, which is how the values
    below read as angles.

    Attributes
    ----------
    directly : float
        0.93 — hedge "directly" at or above (a spike within 6.3° of the axis).
        Pinned by ``test_hedge_bands_on_spikes`` and ``test_layout_directly``. Why: people say
        "directly" only when no deviation is visible.
    plain : float
        0.80 — no hedge at or above (within 18°). Pinned by ``test_hedge_bands_on_spikes`` and
        the seed's "The mug is to the left of the can." layout. Why: a deviation below ~20° is
        not worth a word.
    mostly : float
        0.55 — "mostly" at or above, "loosely" below (within ~40°). Pinned by
        ``test_hedge_bands_on_spikes`` and ``test_layout_loosely``. Why: past ~40° the
        neighbouring direction is nearly as true and "mostly" overstates.
    compound_min : float
        0.35 — both neighbours at least this true for a compound "front-left". Pinned by
        ``test_compound_band_on_spikes``. Why: below it one of the two is not really meant.
    compound_gap : float
        0.15 — and their degrees differ by less than this (spikes within ±6.75° of the
        diagonal). Pinned by ``test_compound_band_on_spikes`` and the seed's "The can is
        front-left of the hat." Why: only near the diagonal is neither direction the main one.
    secondary_min : float
        0.15 — no secondary direction below (a lean under ~13°). Pinned by
        ``test_hedge_bands_on_spikes``. Why: a smaller lean is already covered by "directly"
        or no hedge.
    somewhat : float
        0.30 — "but somewhat S" at or above, "but slightly S" below. Pinned by
        ``test_secondary_bands_on_spikes``. Why: a lean of ~27° and more is clearly visible.
    extends_deviation_deg : float
        15 — "extends to" needs F2's deviation from the primary under this. Pinned by
        ``test_layout_extends``. Why: the near parts (F2) must say "plainly P".
    extends_share : float
        0.20 — ... and at least this share of F0's mass in the neighbour's sector (within 45°
        of S). Pinned by ``test_layout_extends`` and ``test_extends_rule_on_synthetic``. Why: a
        fifth of the shape reaching into S is a visible part of the object, not a corner.
    fits : float
        0.5 — a direction "fits" at or above; "surrounded" needs every direction below. Pinned
        by ``test_layout_surrounded`` and ``test_surround_rule_on_synthetic``. Why: at 0.5 a
        direction is as true as false.
    fits_partly : float
        0.65 — "partly surrounded" needs every direction below this. Pinned by
        ``test_layout_partly_surrounded`` and ``test_layout_overlap_but_direction``. Why: an
        object mostly inside another whose best direction earns only "loosely" is better
        described by the overlap; from "mostly" (~0.55 + margin) on, the direction says more.
    surround_full : float
        0.95 — smoothed F0 coverage for "surrounded". Pinned by ``test_layout_surrounded``.
        Why: allow a few empty degrees from hull noise.
    surround_part : float
        0.5 — coverage for "partly surrounded". Pinned by ``test_layout_partly_surrounded``.
        Why: disjoint convex objects cover at most a half circle, so more needs an overlap.
    coverage_level : float
        0.1 — a direction counts as covered when the smoothed F0 is at least this fraction
        of its maximum. Pinned by ``test_coverage_on_synthetic``. Why: ignores the thin tails
        every overlap produces.
    coverage_smooth_deg : float
        10 — half-width (degrees) of the circular moving average applied to F0 before the
        coverage. Pinned by ``test_coverage_on_synthetic``. Why: hull noise leaves isolated
        empty bins.
    vertical_overlap : float
        0.1 — the footprints must overlap by at least this fraction of the smaller one for a
        vertical relation. Pinned by ``test_vertical_needs_overlap``. Why: objects side by side
        at different heights are described horizontally.
    contact_tolerance : float
        0.05 m — a gap between A's bottom and B's top (5th and 95th percentiles of the points'
        heights) within ± this (or within ``contact_fraction`` of the thinner object's height,
        whichever is larger) is contact: "on top of" / "under". Pinned by
        ``test_vertical_rule``. Why: keypoints seldom sit on the very rim or the very bottom,
        the percentiles trim a little more, and stereo heights are good to a few centimetres.
    contact_fraction : float
        0.25 — see ``contact_tolerance``. Pinned by ``test_vertical_rule``.
    """

    directly: float = 0.93
    plain: float = 0.80
    mostly: float = 0.55
    compound_min: float = 0.35
    compound_gap: float = 0.15
    secondary_min: float = 0.15
    somewhat: float = 0.30
    extends_deviation_deg: float = 15.0
    extends_share: float = 0.20
    fits: float = 0.5
    fits_partly: float = 0.65
    surround_full: float = 0.95
    surround_part: float = 0.5
    coverage_level: float = 0.1
    coverage_smooth_deg: float = 10.0
    vertical_overlap: float = 0.1
    contact_tolerance: float = 0.05
    contact_fraction: float = 0.25


DEFAULT_THRESHOLDS = Thresholds()
