"""NIST CTC-01 (tests/data/step, its QIF plan in tests/data/qif) measured: points planted on its
exact B-rep faces (as tests/test_qif_plan_defects.py plants them), 0.1 µm of noise, in the
nominal frame, written as CSV; and a TOML plan naming its faces (``group = "face:N"``). For the
app's tests of a characteristic shown on the part."""

import os

import numpy as np

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data")
STP = os.path.join(DATA, "step", "nist_ctc_01_asme1_ap242-e1.stp")
QIF = os.path.join(DATA, "qif", "NISTmodels__nist_ctc_01_asme1_ap242.qif")
# CTC-01's features (B-rep face ids): the slot of position 1443 and its datums A, B, C.
SLOT = (38, 42)
DATUMS = {"A": (98,), "B": (90, 91), "C": (76, 77)}
TOML_PLAN = """
[[region]]
name = "slot"
group = ["face:38", "face:42"]
[[region]]
name = "top"
group = "face:98"
[[region]]
name = "hole B"
group = ["face:90", "face:91"]
[[region]]
name = "hole C"
group = ["face:76", "face:77"]
[[datum]]
label = "A"
region = "top"
feature = "plane"
[[datum]]
label = "B"
region = "hole B"
feature = "cylinder"
[[datum]]
label = "C"
region = "hole C"
feature = "cylinder"
[[characteristic]]
id = "7"
type = "position"
feature = "width"
region = "slot"
zone = 0.75
datums = ["A", "B", "C"]
[[characteristic]]
id = "8"
type = "flatness"
region = "top"
zone = 0.2
"""


def measured_csv(folder, n: int = 1500, seed: int = 7, moved: tuple[int, ...] = (),
                 by=(0.0, 0.0, 0.0)) -> str:
    """n points on CTC-01's faces written to ``folder``/ctc01.csv; returns its path. moved :
    faces whose points are moved ``by`` (3,) mm (a feature out of place)."""
    from engine.io.step import read_step
    from sweep import on_part

    rng = np.random.default_rng(seed)
    P, N, F = on_part(read_step(STP), rng, n)
    P = P + rng.normal(0.0, 1e-4, len(P))[:, None] * N
    P[np.isin(F, moved)] += np.asarray(by, float)
    path = os.path.join(str(folder), "ctc01.csv")
    np.savetxt(path, P, delimiter=",", header="x,y,z", comments="", fmt="%.9f")
    return path


def toml_plan(folder) -> str:
    """CTC-01's slot position and top flatness as a TOML plan on its face ids; its path."""
    path = os.path.join(str(folder), "ctc01_plan.toml")
    with open(path, "w", encoding="utf-8") as f:
        f.write(TOML_PLAN)
    return path


def tessellation_faces():
    """(triangles (m, 3), the face id of each) of CTC-01's tessellation, read here apart from
    the app."""
    from engine.io.step import read_step

    step = read_step(STP)
    tris = step.point_set.triangles
    return tris, np.asarray(step.face_ids)[tris[:, 0]]
