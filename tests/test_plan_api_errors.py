"""A plan built in code (engine.gdt.plan, as the QIF reader and the tests build theirs) skips the
plan file's checks: a characteristic that lacks what its type needs, or names a datum the plan
does not have, is an InputError naming it, not a TypeError from deep in the arithmetic (the
type checker found these: an angle, a spacing or a datum's parts that may be None)."""

import numpy as np
import pytest

from engine.errors import InputError
from engine.gdt.plan import (Alignment, Characteristic, Datum, Part, Plan, Region,
                             known_datum_parts)
from engine.nominal import Nominal
from engine.pointset import PointSet
from plan_runs import run

REGIONS = (Region("A", box=((-1, -1, -0.5), (51, 31, 0.5))),
           Region("B", box=((-0.5, -1, 0.5), (0.5, 31, 9.5))),
           Region("C", box=((0.5, -0.5, 0.5), (49.5, 0.5, 9.5))),
           Region("top", box=((0.5, 0.5, 9.5), (49.5, 29.5, 10.5))))
DATUMS = (Datum("A", "A", "plane"), Datum("B", "B", "plane"), Datum("C", "C", "plane"))


def _block(rng, k):
    """Points and outward normals of a block's base A, sides B and C and top, k a face."""
    u, v = rng.uniform(0, 1, (2, k))
    faces = [(np.column_stack([50 * u, 30 * v, 0 * u]), [0, 0, -1.0]),
             (np.column_stack([0 * u, 30 * v, 10 * u]), [-1.0, 0, 0]),
             (np.column_stack([50 * u, 0 * u, 10 * v]), [0, -1.0, 0]),
             (np.column_stack([50 * u, 30 * v, 10 + 0 * u]), [0, 0, 1.0])]
    return (np.vstack([p for p, _ in faces]),
            np.vstack([np.broadcast_to(np.asarray(n), p.shape) for p, n in faces]))


@pytest.fixture(scope="module")
def part():
    rng = np.random.default_rng(1)
    nominal = Nominal.from_point_set(PointSet(*_block(rng, 2000)))
    M = _block(rng, 200)[0]
    return nominal, M + rng.normal(0, 0.001, M.shape)


@pytest.mark.parametrize("c, words", [
    (Characteristic("1", "angularity", "top", 0.0, 0.05, ("A",)), "states its basic angle"),
    (Characteristic("2", "line_profile", "top", -0.05, 0.05, direction=(1.0, 0.0, 0.0)),
     "needs a 'direction'"),
    (Characteristic("3", "parallelism", "top", 0.0, 0.05, ("Z",)), "'Z' is not the label"),
    (Characteristic("4", "circular_runout", "top", 0.0, 0.05, ("Z",)), "'Z' is not the label"),
    (Characteristic("5", "position", "top", 0.0, 0.05, ("A-Z",), kind="width"),
     "'A-Z' is not the label")])
def test_a_characteristic_built_in_code_without_what_it_needs_is_an_input_error(part, c, words):
    nominal, M = part
    plan = Plan("plan.toml", "0" * 64, Part(), REGIONS, DATUMS, Alignment("best-fit"), (c,))
    with pytest.raises(InputError, match=words):
        run(nominal, M, None, plan)


def test_known_datum_parts_resolves_a_datum_and_a_common_datum_else_refuses():
    assert known_datum_parts("A", ["A", "B"]) == ("A",)
    assert known_datum_parts("A-B", ["A", "B"]) == ("A", "B")
    with pytest.raises(InputError, match="'A-C' is not the label of any"):
        known_datum_parts("A-C", ["A", "B"])
