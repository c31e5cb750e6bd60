"""The sped-up paths of labelling and relations give bit-identical results to the old code.

``direction_degree`` now reads its index arrays and window weights from a per-size cache and
rotates with slicing instead of ``np.roll``; the homography checks of the database compute
the Jacobians without stacking and ``w`` without the Jacobians. The references below are the
previous implementations, verbatim.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenespeak.perception import database
from scenespeak.spatial.degrees import (
    TAU_FLAT_DEG,
    TAU_ZERO_DEG,
    DirectionDegree,
    _cancel_side,
    direction_degree,
)


def _reference_degree(h: np.ndarray, index: int) -> DirectionDegree:
    nbins = h.size
    n = nbins // 4
    g = np.roll(h, -index).astype(np.float64)
    bin_rad = 2.0 * np.pi / nbins
    phis = np.arange(n - 1, -1, -1)
    dist = (n - phis).astype(np.float64)
    fav_pos = g[phis].copy()
    fav_neg = g[(-phis) % nbins].copy()
    fav_pos[-1] *= 0.5
    fav_neg[-1] *= 0.5
    cphi = np.arange(n, 2 * n)
    con_pos = g[cphi]
    con_neg = g[(-cphi) % nbins]
    opposite = 0.5 * g[2 * n]
    arm = (cphi - n).astype(np.float64)
    m_pos = float(con_pos @ arm) + opposite * n
    m_neg = float(con_neg @ arm) + opposite * n
    contrary = float(con_pos.sum() + con_neg.sum()) + 2.0 * opposite
    contrary += _cancel_side(fav_pos, dist, m_pos)
    contrary += _cancel_side(fav_neg, dist, m_neg)
    eff = np.concatenate([fav_neg[:-1], [fav_pos[-1] + fav_neg[-1]], fav_pos[::-1][1:]])
    phi = np.arange(-(n - 1), n) * bin_rad
    total = float(eff.sum())
    scale = max(total + contrary, 1e-300)
    if total <= 1e-12 * scale:
        return DirectionDegree(0.0, 0.0, max(total, 0.0), contrary)
    absdeg = np.degrees(np.abs(phi))
    weight = np.clip((TAU_ZERO_DEG - absdeg) / (TAU_ZERO_DEG - TAU_FLAT_DEG), 0.0, 1.0)
    tau = float(weight @ eff / weight.sum())
    above = np.maximum(eff - tau, 0.0)
    mass = float(above.sum())
    theta = float(above @ phi / mass) if mass > 0.0 else float(eff @ phi / total)
    degree = max(0.0, 1.0 - abs(theta) / (np.pi / 2.0)) * total / (total + contrary)
    return DirectionDegree(float(min(max(degree, 0.0), 1.0)), theta, total, contrary)


@pytest.mark.parametrize("nbins", [8, 36, 180])
def test_direction_degree_matches_the_reference_bit_for_bit(nbins: int) -> None:
    rng = np.random.default_rng(nbins)
    for trial in range(150):
        kind = trial % 3
        if kind == 0:  # dense random
            h = rng.random(nbins)
        elif kind == 1:  # sparse spikes
            h = np.zeros(nbins)
            h[rng.integers(0, nbins, 3)] = rng.random(3)
        else:  # a bump, float32 input
            centre = rng.integers(0, nbins)
            d = np.minimum(
                np.abs(np.arange(nbins) - centre), nbins - np.abs(np.arange(nbins) - centre)
            )
            h = np.exp(-((d / (nbins / 12)) ** 2)).astype(np.float32)
        for index in (*(k * nbins // 4 for k in range(4)), int(rng.integers(0, nbins))):
            assert direction_degree(h, index) == _reference_degree(h, index)


def _ref_local_jacobians(h: np.ndarray, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    x, y = pts[:, 0], pts[:, 1]
    u = h[0, 0] * x + h[0, 1] * y + h[0, 2]
    v = h[1, 0] * x + h[1, 1] * y + h[1, 2]
    w = h[2, 0] * x + h[2, 1] * y + h[2, 2]
    j00 = (h[0, 0] * w - u * h[2, 0]) / w**2
    j01 = (h[0, 1] * w - u * h[2, 1]) / w**2
    j10 = (h[1, 0] * w - v * h[2, 0]) / w**2
    j11 = (h[1, 1] * w - v * h[2, 1]) / w**2
    return np.stack([j00, j01, j10, j11], axis=1), w


def _ref_plausible(h: np.ndarray, outline: np.ndarray, t_xy: np.ndarray) -> bool:
    if not np.all(np.isfinite(h)):
        return False
    pts = np.vstack([outline.astype(np.float64), t_xy])
    _, w = _ref_local_jacobians(h, pts)
    if np.any(w <= 0):
        return False
    jc, _ = _ref_local_jacobians(h, t_xy.mean(axis=0, keepdims=True))
    a = jc[0].reshape(2, 2)
    if np.linalg.det(a) <= 0:
        return False
    sv = np.linalg.svd(a, compute_uv=False)
    if sv[1] <= 0 or sv[0] / sv[1] > 8.0:
        return False
    return 1.0 / 64.0 <= math.sqrt(sv[0] * sv[1]) <= 64.0


def test_homography_checks_match_the_reference() -> None:
    rng = np.random.default_rng(7)
    outline = np.array([[0, 0], [200, 0], [200, 150], [0, 150]], np.float32)
    verdicts = set()
    for _ in range(300):
        h = np.eye(3) + rng.normal(0.0, 0.3, (3, 3)) * [[1, 1, 100], [1, 1, 100], [1e-3, 1e-3, 0]]
        t_xy = rng.uniform(0, 200, (40, 2))
        q_xy = np.c_[t_xy, np.ones(40)] @ h.T
        q_xy = q_xy[:, :2] / q_xy[:, 2:3] + rng.normal(0, 3, (40, 2))
        t_size = rng.uniform(1, 10, 40).astype(np.float32)
        q_size = (t_size * rng.uniform(0.5, 2.5, 40)).astype(np.float32)
        t_angle = rng.uniform(0, 360, 40).astype(np.float32)
        q_angle = (t_angle + rng.normal(0, 40, 40)).astype(np.float32)
        jac, w = database._local_jacobians(h, t_xy)
        ref_jac, ref_w = _ref_local_jacobians(h, t_xy)
        np.testing.assert_array_equal(np.stack(jac, axis=1), ref_jac)
        np.testing.assert_array_equal(w, ref_w)
        verdict = database._plausible(h, outline, t_xy)
        assert verdict == _ref_plausible(h, outline, t_xy)
        verdicts.add(verdict)
        ok = database._consistent(h, t_xy, t_size, t_angle, q_xy, q_size, q_angle, 4.0, 2.0, 30.0)
        det = ref_jac[:, 0] * ref_jac[:, 3] - ref_jac[:, 1] * ref_jac[:, 2]
        ref_proj = np.c_[t_xy, np.ones(40)] @ h.T
        ref_proj = ref_proj[:, :2] / ref_proj[:, 2:3]
        ref_ok = (ref_w > 0) & (np.linalg.norm(ref_proj - q_xy, axis=1) <= 4.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = (q_size / np.maximum(t_size, 1e-6)) / np.sqrt(np.abs(det))
            ref_ok &= np.abs(np.log(ratio)) <= math.log(2.0)
        rot = np.degrees(np.arctan2(ref_jac[:, 2] - ref_jac[:, 1], ref_jac[:, 0] + ref_jac[:, 3]))
        dang = (q_angle.astype(np.float64) - t_angle - rot + 180.0) % 360.0 - 180.0
        ref_ok &= (np.abs(dang) <= 30.0) & np.isfinite(ratio)
        np.testing.assert_array_equal(ok, ref_ok)
    assert verdicts == {True, False}  # both branches exercised


def test_blas_limit_is_reused_and_restores() -> None:
    threadpoolctl = pytest.importorskip("threadpoolctl")
    before = [i["num_threads"] for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas"]
    with database._single_threaded_blas():
        inside = [
            i["num_threads"] for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas"
        ]
        assert all(n == 1 for n in inside)
    after = [i["num_threads"] for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas"]
    assert after == before
    import sys

    assert database._blas_controller(len(sys.modules)) is database._blas_controller(
        len(sys.modules)
    )
