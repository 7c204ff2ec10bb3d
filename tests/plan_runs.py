"""Helpers the plan tests share: a synthetic part inspected from its measured pose and judged
by a plan, and one characteristic's result picked out of it."""

from engine.gdt.characteristics import inspect_plan
from engine.inspection import Tolerance, inspect


def run(nominal, M, labels, plan, **kwargs):
    """Inspect the measured points M (any pose) against ``nominal`` at ±0.5 mm (the zone the
    plan tests do not judge by) and judge ``plan``'s characteristics; kwargs go to inspect."""
    res = inspect(nominal, M, Tolerance.symmetric(0.5), **kwargs)
    return inspect_plan(res, plan, nominal, None, M, labels, False)


def by_id(res, i):
    """The plan result of characteristic ``i``."""
    return next(r for r in res.plan.characteristics if r.characteristic.id == i)
