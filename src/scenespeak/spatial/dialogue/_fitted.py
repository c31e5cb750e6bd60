"""Fitted constants of :mod:`scenespeak.spatial.dialogue.uncertainty` (written by
``python benchmarks/bench_dialogue.py fit /tmp/talk/train7100``; do not edit by hand).

``SIGMA_PX``: the disparity error σ_d in pixels, from the depth errors of the objects found in
the training scenes (robust: 1.4826 × the median absolute deviation of ΔZ·f·B/Z²).
``WEIGHTS``: the logistic model (intercept, self-assessment, primary degree, margin in σ),
fitted by Newton's method on 442 described pairs (410 right); the margin's weight
is held at 0 when the free fit makes it negative (the confidence must not fall as the margin
grows).
"""

SIGMA_PX = 0.9266
WEIGHTS = (-21.8257, 8.3910, 35.5364, 0.0000)
TRAINING = "train7100: 40 scenes, 442 pairs"
