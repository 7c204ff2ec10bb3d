"""Each characteristic type judged (profile with or without datums, flatness; the other form
types in engine.gdt.form, the orientation types in engine.gdt.orientation, the location types
in engine.gdt.location, size in engine.gdt.size),
with the work a plan's characteristics share done once (Shared), and the part's verdict from
theirs."""

from __future__ import annotations

import copy
from dataclasses import replace

import numpy as np

from ..choices import Fit
from ..fits import minimax_pose
from ..tolerance import Tolerance
from ..verdict import ACCEPT, INCONCLUSIVE, REJECT, pointwise_verdict
from .datums import Alignment, align
from .decision import by_value, own, untrusted, value_guard
from .form import judge_form
from .location import judge_location
from .orientation import judge_orientation
from .plan import (DIMENSIONS, FORM, MIN_POINTS, ORIENTATION, RUNOUT, Characteristic, Plan,
                   known_datum_parts)
from .region_features import (FACING, SPAN, datum_invariants, datum_nominal,
                              datum_surface)
from .results import WORST, CharacteristicResult, Geometry
from .size import judge_size

PROGRESS_REPORTS = 200
"""At most this many progress reports over a plan's characteristics (engine.progress): one for
each would cost the desktop app a repaint per characteristic."""


class Shared:
    """What the characteristics of one plan evaluation share, computed once each: the poses
    their datums give, and each region's fits and deviations (a plan may hold thousands of
    characteristics on a few regions; only the judgement against each one's zone is its
    own). Every entry depends on the plan, the part and its key alone, never on the order in
    which the characteristics ask for it, so a shared result is the one a plan of that single
    characteristic gives."""

    def __init__(self, plan: Plan, geo: Geometry, members: dict[str, np.ndarray]):
        self.datums = {d.label: d for d in plan.datums}
        self.geo, self.members = geo, members
        self.sizes = {c.region: c for c in plan.characteristics if c.type == "size"}
        """{region: its size characteristic}: the limits a position at MMC or LMC departs
        from."""
        self.memo: dict = {}

    def once(self, key: tuple, compute):
        """compute()'s value, computed on the first call with ``key`` only; a FeatureError
        (the region's points do not determine its feature) is kept and raised again."""
        from .features import FeatureError

        if key not in self.memo:
            try:
                self.memo[key] = compute()
            except FeatureError as e:
                self.memo[key] = e
        got = self.memo[key]
        if isinstance(got, FeatureError):
            raise got.with_traceback(None)
        return got

    def datum(self, label: str):
        """The datum a reference names: the plan's, or a common datum "A-B" as one datum of
        its parts' feature and fit (its nominal: the first part's region's; its points:
        :meth:`datum_members`)."""
        if label in self.datums:
            return self.datums[label]
        return replace(self.datums[known_datum_parts(label, self.datums)[0]], label=label)

    def datum_members(self, label: str) -> np.ndarray:
        """The measured points of a datum's region (a common datum: of both its regions)."""
        return np.unique(np.concatenate([self.members[self.datums[p].region]
                                         for p in known_datum_parts(label, self.datums)]))

    def placed(self, labels: tuple, best_fit: tuple, T_start: np.ndarray) -> Alignment:
        """The part placed by the datums ``labels`` (primary first), the freedom they leave
        best-fitted on the regions ``best_fit``, from ``T_start`` (engine.gdt.datums.align)."""
        return self.once(self.placed_key(labels, best_fit, T_start),
                         lambda: self._align(labels, best_fit, T_start))

    def datum_nominal(self, label: str) -> dict | None:
        """The nominal feature of the datum ``label`` (engine.gdt.region_features
        .datum_nominal; a common datum's: its first part's), once per plan evaluation."""
        return self.once(("datum nominal", label),
                         lambda: datum_nominal(self.datum(label), self.geo))

    @staticmethod
    def placed_key(labels: tuple, best_fit: tuple, T_start: np.ndarray) -> tuple:
        """The memo key of :meth:`placed` with these arguments."""
        return ("placed", labels, best_fit, id(T_start))

    def with_frame(self, frame: tuple, al: Alignment) -> "Shared":
        """A fresh evaluation of the same plan in which ``placed(*frame)`` is ``al``."""
        again = copy.copy(self)
        again.memo = {self.placed_key(*frame): al}
        return again

    def _align(self, labels: tuple, best_fit: tuple, T_start: np.ndarray) -> Alignment:
        geo, members = self.geo, self.members
        ds = [self.datum(x) for x in labels]
        fit_idx = np.unique(np.concatenate([members[r] for r in best_fit])) \
            if best_fit else None
        # A common datum "A-B" is fitted to the nominal surface: its parts' features differ.
        nominals = [self.datum_nominal(x) for x in labels]
        surfaces = [datum_surface(d, geo, n) if x in self.datums else None
                    for x, d, n in zip(labels, ds, nominals)]
        invariants = [datum_invariants(d, geo, n) for d, n in zip(ds, nominals)]
        return align(geo.evaluate, T_start, ds, [self.datum_members(x) for x in labels],
                     geo.centre, geo.length, fit_idx, invariants, surfaces)


def plan_verdict(results, alignment: Alignment | None) -> tuple[str, tuple[str, ...]]:
    verdict, reasons = part_verdict(results)
    if alignment is not None and not alignment.complete:
        reasons = (f"the part's alignment is incomplete: {alignment.message}", *reasons)
    return verdict, reasons


def part_verdict(results) -> tuple[str, tuple[str, ...]]:
    """REJECT if any characteristic is out, else INCONCLUSIVE if any cannot be trusted, else
    ACCEPT; the reasons name them."""
    out = [r for r in results if r.verdict == REJECT]
    unsure = [r for r in results if r.verdict == INCONCLUSIVE]
    if out:
        return REJECT, tuple(f"{r.characteristic.called} is out of tolerance: {r.reason}"
                             for r in out)
    if unsure:
        return INCONCLUSIVE, tuple(f"{r.characteristic.called} cannot be decided: {r.reason}"
                                   for r in unsure)
    return ACCEPT, ((f"all {len(results)} characteristics are within tolerance"
                     if len(results) != 1 else "its one characteristic is within tolerance"),)


def judge(c: Characteristic, idx: np.ndarray, geo: Geometry, shared: Shared, T_part):
    planar = geo.nominal_points.shape[1] == 2
    kind = {"plane": "line", "cylinder": "circle"}.get(c.feature, c.feature) if planar \
        else c.feature
    need = 1 if c.type == "profile" else MIN_POINTS.get(kind, 1)  # a runout's surface: any
    if idx.size < need:
        return CharacteristicResult(c, None, INCONCLUSIVE,
                                    f"region '{c.region}' has {idx.size} measured points; "
                                    f"{c.type} needs at least {need}", idx)
    from .features import FeatureError

    try:
        if c.type in ("profile", "line_profile"):
            return _profile(c, idx, geo, shared)
        if c.type in RUNOUT:
            from .runout import judge_runout

            return judge_runout(c, idx, geo, shared)
        if c.type == "flatness":
            return _flatness(c, idx, geo, shared)
        if c.type in FORM:
            return judge_form(c, idx, geo, shared)
        if c.type in ORIENTATION:
            return judge_orientation(c, idx, geo, shared, T_part)
        if c.type == "size":
            return judge_size(c, idx, geo, shared)
        if c.type in DIMENSIONS:
            from .dimensions import judge_dimension

            return judge_dimension(c, idx, geo, shared)
        return judge_location(c, idx, geo, shared, T_part)
    except FeatureError as e:
        # The region's points do not determine its feature (all on a line, ...): say so.
        return CharacteristicResult(c, None, INCONCLUSIVE, f"region '{c.region}': {e.message}",
                                    idx)


def _profile(c: Characteristic, idx: np.ndarray, geo: Geometry, shared: Shared):
    tol = Tolerance(c.lower, c.upper)
    # The pose depends on the region and the datums or the refit; a minimax refit also on the
    # zone it centres on.
    key = ("profile", c.region, tuple(c.datums)) if c.datums else \
        ("profile", c.region, c.fit) + ((c.lower, c.upper) if c.fit == "minimax" else ())
    got = shared.once(key, lambda: _profile_pose(c, idx, geo, shared))
    if isinstance(got, CharacteristicResult):
        return own(got, c)
    T, d, margin, facts = got
    if c.type == "line_profile":
        from .line_profile import judge_line_profile

        return judge_line_profile(c, idx, geo, T, facts)
    verdict, reason = pointwise_verdict(d, tol, margin)
    centre = 0.5 * (c.lower + c.upper)
    value = float(2.0 * np.max(np.abs(d - centre)))
    ex = tol.excess(d)
    worst = tuple(int(idx[i]) for i in np.argsort(-ex, kind="stable")[:WORST])
    return CharacteristicResult(c, value, verdict, reason, idx, d, worst,
                                {**facts, "T_nominal_measured": T})


def _profile_pose(c: Characteristic, idx: np.ndarray, geo: Geometry, shared: Shared):
    """(pose T, the region's deviations d there, their guard band, facts) of a profile, or an
    INCONCLUSIVE result when its datums cannot place the part."""
    facts: dict = {}
    if c.datums:
        al = shared.placed(tuple(c.datums), (c.region,), geo.T0)
        if not al.complete:
            return untrusted(c, idx, al)
        T = al.T_nominal_measured
        facts["free"] = [f.describe() for f in al.free]
    elif c.fit == Fit.MINIMAX:
        def evaluate(Tc):
            return geo.evaluate(Tc, idx)

        T = minimax_pose(evaluate, geo.T0, c.lower, c.upper).T
    else:
        T = align(geo.evaluate, geo.T0, [], [], geo.centre, geo.length, idx).T_nominal_measured
    return T, geo.evaluate(T, idx)[1], geo.margin(idx, T), facts


def _flatness(c: Characteristic, idx: np.ndarray, geo: Geometry, shared: Shared):
    got = shared.once(("flatness", c.region), lambda: _flat(c, idx, geo))
    if isinstance(got, CharacteristicResult):
        return own(got, c)
    width, normal, guard = got
    return by_value(c, idx, width, {"normal": normal}, "minimum-zone width", guard)


def _flat(c: Characteristic, idx: np.ndarray, geo: Geometry):
    """(minimum-zone width, its normal, the width's uncertainty bound) of the region's points,
    or an INCONCLUSIVE result when they do not determine its plane."""
    from .features import flatness

    X, _, n = geo.evaluate(geo.T0, idx)
    hint = n.mean(axis=0) / np.linalg.norm(n.mean(axis=0))
    if X.shape[1] == 3:
        flat = X - X.mean(axis=0)
        flat -= np.outer(flat @ hint, hint)
        ev = np.linalg.eigvalsh(flat.T @ flat)  # (0, smaller, larger) spreads in the plane
        if ev[1] < SPAN ** 2 * ev[2]:
            return CharacteristicResult(c, None, INCONCLUSIVE, f"the {idx.size} points of "
                                        f"region '{c.region}' lie along a line: they do not "
                                        "determine a plane", idx)
    f = flatness(X, hint)
    turn = float(np.degrees(np.arccos(np.clip(f.normal @ hint, -1.0, 1.0))))
    if turn > np.degrees(FACING):
        return CharacteristicResult(c, None, INCONCLUSIVE, f"the points' minimum zone stands "
                                    f"at {turn:.0f}° to the nominal face: they do not "
                                    "determine its plane", idx)
    return f.width, f.normal, value_guard(geo, idx, geo.T0, form_only=True)
