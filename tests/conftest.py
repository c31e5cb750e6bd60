"""Shared test settings.

Hypothesis runs derandomised (a fixed seed), without deadlines (the machine is shared and
noisy), so CI results are reproducible.
"""

from __future__ import annotations

from hypothesis import HealthCheck, settings

settings.register_profile(
    "scenespeak",
    derandomize=True,
    deadline=None,
    max_examples=60,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile("scenespeak")
