"""Whether a characteristic's verdict survives the scatter of its datums' points.

A datum reference frame is fitted to measured points, and their scatter (the probe's noise, the
form its sampling sees) moves it: a width datum of two 15 mm walls probed with 13 points at
20 um of noise turns NIST CTC-01's frame by up to 0.006 rad, which moves a slot 600 mm away by
3 mm. engine.gdt.datums.frame_scatter gives the frame's principal 1-sigma motions; each
characteristic relative to datums whose value lies near enough a limit for them to matter is
judged again with its frame moved within PROBE sigmas of them (along each axis, then where
the value is least or greatest: :func:`_extremes`), and is INCONCLUSIVE where its verdict
changes there (the verdict could really differ), saying how far its value runs.
The registration's own pose uncertainty is engine.pose_sensitivity's; this is the plan's.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..errors import InputError
from ..pose import apply_transform, largest_speed
from ..pose_sensitivity import PROBE_SIGMAS
from ..verdict import INCONCLUSIVE, REJECT
from .datums import Alignment, moved_along
from .plan import LOCATION, ORIENTATION, ZONE_ONLY
from .results import CharacteristicResult, Geometry

PROBE = PROBE_SIGMAS[-1]
"""The frame is moved up to this many sigmas along each principal axis of its scatter, each way
(the registration's weak directions are probed as far) ..."""
ACTIVE = 3
"""The scatter's axes that move the value most, whose cross terms are probed (_extremes)."""


def frame_of(c, geo: Geometry, T_part) -> tuple | None:
    """The arguments of the ``Shared.placed`` call that places characteristic ``c`` (engine.gdt
    .judgement: a profile from the registration's pose, its freedom best-fitted on its region;
    a location or orientation from the plan's alignment), or None when it has no datum frame
    of that kind (a runout's datum axis is its own)."""
    if not c.datums:
        return None
    if c.type in ("profile", "line_profile"):
        return tuple(c.datums), (c.region,), geo.T0
    if c.type in LOCATION or c.type in ORIENTATION:
        return tuple(c.datums), (), T_part
    return None


def probed(results: list[CharacteristicResult], geo: Geometry, shared, T_part,
           only: set | None = None) -> list[CharacteristicResult]:
    """``results`` with each characteristic whose verdict changes within PROBE sigmas of its
    frame's scatter INCONCLUSIVE (module docstring); ``shared``: the plan evaluation's
    engine.gdt.judgement.Shared, whose frames are the ones judged; ``only``: the ids of the
    characteristics probed (None: every one)."""
    out = []
    for r in results:
        c = r.characteristic
        frame = frame_of(c, geo, T_part)
        if frame is None or r.value is None or r.verdict == INCONCLUSIVE or (
                only is not None and c.id not in only):
            out.append(r)
            continue
        al = shared.placed(*frame)
        # The same characteristic under other names (a plan's copies) is probed once.
        same = replace(c, id="", name="", designator="", source="")
        seen = shared.once(("frame probe", shared.placed_key(*frame), same),
                           lambda: _probe(r, al, frame, shared, geo, T_part))
        other = next((g.verdict for g in seen if g.verdict != r.verdict), None)
        if other is None:
            out.append(r)
            continue
        values = [g.value for g in seen] + [r.value]
        lo, hi = min(values), max(values)
        out.append(replace(r, verdict=INCONCLUSIVE, reason=(
            f"{r.reason}; but the scatter of its datums' points leaves their frame uncertain "
            f"({_scatters(al)}): moved within {PROBE:g} sigma of it the value runs from "
            f"{lo:.4f} to {hi:.4f} mm and the verdict would be {other}, so it depends on where "
            f"the datums' points put the frame"), facts={
                **r.facts, "frame_scatter_values": [float(lo), float(hi)]}))
    return out


def _probe(r: CharacteristicResult, al: Alignment, frame: tuple, shared, geo: Geometry,
           T_part) -> list[CharacteristicResult]:
    """The characteristic of ``r`` judged with its frame ``al`` (placed by ``frame``, the
    arguments of Shared.placed) moved within PROBE sigmas of its scatter (:func:`_extremes`);
    [] when no such motion can move its value across a limit."""
    from .judgement import judge

    S = _reaching(al, r, geo)
    if S is None or r.value is None:
        return []

    def at(u):
        """The characteristic judged with its frame moved by S u (u in sigmas), or None."""
        again = shared.with_frame(frame, replace(al, T_nominal_measured=moved_along(
            al.T_nominal_measured, S @ u, geo.centre, geo.length)))
        try:
            got = judge(r.characteristic, r.indices, geo, again, T_part)
        except InputError:
            return None
        return None if got.value is None else got

    return _extremes(at, S.shape[1], r.value, r.verdict == REJECT)


def _reaching(al: Alignment, r: CharacteristicResult, geo: Geometry) -> np.ndarray | None:
    """The frame's scatter (dof, q; bootstrapped) when a motion within PROBE sigmas of it can
    move the characteristic's value across a limit; None when none can (screened on the
    cheaper first-order scatter, which is larger): every such motion moves its
    points by less than half the value's distance to its nearest limit (a zone's width, a
    profile's and a position's value move by at most twice their points' displacement)."""
    if al.bootstrapped is None or geo.points is None or r.indices.size == 0:
        return None
    S = al.scatter
    if S is None or S.shape[1] == 0:
        return None
    X = apply_transform(al.T_nominal_measured, geo.points[r.indices])
    # A motion S u, |u| <= PROBE, moves a point by at most PROBE * sqrt(sum_j |S_j at x|^2).
    reach = PROBE * float(np.sqrt(sum(largest_speed(S[:, j], X, geo.centre, geo.length) ** 2
                                      for j in range(S.shape[1]))))
    if 2.0 * reach < _room(r):
        return None
    return al.bootstrapped()


def _extremes(at, q: int, value: float, lower: bool) -> list:
    """The characteristic judged at frames within PROBE sigmas of its scatter that move its
    value most: down (``lower``: a REJECT's value towards its limit) or up.

    at(u) -> the result with the frame moved u (q,) sigmas along the scatter's axes, or None.
    The value's square is modelled as quadratic in u (exactly so for a position, the length of
    an offset linear in the motion; a profile's or a zone's largest excursion piecewise):
    its slope and curvature along each axis from +-1 sigma, the cross terms of the ACTIVE
    axes that move it most from one more frame each; then the frame at its least (the
    model's minimum, within the PROBE sphere) or greatest (on the sphere: along the slope
    and along the steepest curvature) is judged too."""
    eye = np.eye(q)
    seen, F0 = [], value ** 2
    Fm, Fp = np.full(q, F0), np.full(q, F0)
    for j in range(q):
        for k, F in ((-1.0, Fm), (1.0, Fp)):
            got = at(k * eye[j])
            if got is not None:
                seen.append(got)
                F[j] = got.value ** 2
    g, h = 0.5 * (Fp - Fm), Fp - 2.0 * F0 + Fm
    active = np.argsort(-(np.abs(g) + np.abs(h)), kind="stable")[:ACTIVE]
    H = np.diag(h[active])
    for a, i in enumerate(active):
        for b in range(a + 1, len(active)):
            j = active[b]
            got = at(eye[i] + eye[j])
            if got is not None:
                seen.append(got)
                H[a, b] = H[b, a] = got.value ** 2 - F0 - g[i] - g[j] - 0.5 * (h[i] + h[j])
    ga = g[active]
    if not np.any(ga) and not np.any(H):
        return seen
    tries = []
    w, V = np.linalg.eigh(H)
    if lower:
        # The model's minimum along the ways it curves up (a way it hardly curves along moves
        # the value little: left out, not divided by nearly 0), and its least along the
        # slope; each within the PROBE sphere.
        up = w > 1e-3 * max(float(w.max()), 0.0)
        tries.append(-V[:, up] @ ((V[:, up].T @ ga) / w[up]) if up.any() else ga * 0.0)
        d = -ga / (np.linalg.norm(ga) or 1.0)
        curve = float(d @ H @ d)
        tries.append(d * (float(np.linalg.norm(ga)) / curve if curve > 0.0 else PROBE))
    else:  # the greatest lies on the sphere: along the slope, and the steepest curvature's way
        top = V[:, -1] * (1.0 if float(ga @ V[:, -1]) >= 0.0 else -1.0)
        tries += [ga / (np.linalg.norm(ga) or 1.0) * PROBE, top * PROBE]
    for u in tries:
        n = float(np.linalg.norm(u))
        if n == 0.0 or not np.isfinite(n):
            continue
        full = np.zeros(q)
        full[active] = u * min(1.0, PROBE / n)
        got = at(full)
        if got is not None:
            seen.append(got)
    return seen


def _room(r: CharacteristicResult) -> float:
    """How far the value of ``r`` lies from where its verdict changes, mm (0: always probe)."""
    c = r.characteristic
    if "features" in r.facts or c.unit != "mm":  # a pattern's features: each its own limit
        return 0.0
    hi = r.facts.get("allowed", (c.nominal or 0.0) + c.upper)
    limits = [hi] if c.type in ZONE_ONLY else [hi, (c.nominal or 0.0) + c.lower]
    guard = float(r.facts.get("uncertainty_bound") or 0.0)
    return max(0.0, min(abs(r.value - x) for x in limits) - guard)


def _scatters(al: Alignment) -> str:
    """The datums' scatters in words: "datum B 0.0200 mm over 13 points, …"."""
    took = [f for f in al.datums if f.constrained]
    return ", ".join(f"datum {f.label} {s:.4f} mm over {f.n_points:,} points"
                     for f, s in zip(took, al.scatter_sigma) if np.isfinite(s))
