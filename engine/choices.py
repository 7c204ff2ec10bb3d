"""The named choices of an inspection and the words of its outcome, as string enums: their values
are the words every output writes (JSON, CSV, QIF, the certificate) and every front end accepts,
so a member equals and serialises as its word. A light module: the desktop app's session and the
settings hold them without loading the engine."""

from __future__ import annotations

from enum import StrEnum


class Verdict(StrEnum):
    """A part's (or a characteristic's) verdict (engine.verdict says how it is reached)."""

    ACCEPT = "ACCEPT"
    REJECT = "REJECT"
    INCONCLUSIVE = "INCONCLUSIVE"


class Fit(StrEnum):
    """The pose the deviations are judged at: the least-squares best fit, or the minimax pose
    that minimises the largest excursion from the zone's centre ("can the part be placed inside
    its zone?", engine.fits)."""

    LSQ = "lsq"
    MINIMAX = "minimax"


class DecisionRule(StrEnum):
    """How deviations are judged against the zone: every point inside it (simple), or inside it
    shrunk by each point's expanded uncertainty (guarded, ISO 14253-1; engine.verdict)."""

    SIMPLE = "simple"
    GUARDED = "guarded"
