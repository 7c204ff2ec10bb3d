"""The engine's random streams, all drawn from one seed (:attr:`InspectionSettings.seed`).

Each place that makes a random choice (a seeded subset of the points, RANSAC hypotheses, a
nominal's coarse levels) owns a stream: a fixed number of its module, e.g. ``SPREAD_SEED`` in
engine.neighbours. :func:`rng` gives that stream's generator for an inspection's seed. Seed 0,
the default, gives each stream the generator it had before there was a seed
(``default_rng(stream)``), so the outputs of an inspection with default settings stay what
they were; any other seed gives every stream a generator of its own from the pair
``[seed, stream]`` (numpy's SeedSequence), so two streams never share one.
"""

from __future__ import annotations

import numpy as np

DEFAULT_SEED = 0
"""The seed of an inspection that names none (engine.settings.InspectionSettings.seed)."""


def rng(seed: int, stream: int) -> np.random.Generator:
    """The generator of random ``stream`` (a module's fixed number) under base ``seed`` (>= 0).

    >>> a, b = rng(0, 7).integers(1000, size=3), np.random.default_rng(7).integers(1000, size=3)
    >>> bool((a == b).all())
    True
    >>> bool((rng(1, 7).integers(1000, size=3) == rng(1, 7).integers(1000, size=3)).all())
    True
    """
    return np.random.default_rng(stream if seed == DEFAULT_SEED else [seed, stream])
