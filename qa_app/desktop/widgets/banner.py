"""The verdict banner: the verdict in large type with its reasons, the statistics, the plan and
how far the verdict depends on the pose; OUT OF DATE when the result is stale.
"""

from __future__ import annotations

import os

from PySide6.QtWidgets import QFrame, QLabel, QVBoxLayout

from engine.choices import Verdict
from reports.messages import VERDICT_RGB, VERDICT_WORD

from ..model import Session
from .colours import qcolor


class VerdictBanner(QFrame):
    """The verdict in large type with its reason and the statistics; when the result is stale,
    "OUT OF DATE" with what changed, and the old verdict greyed."""

    def __init__(self, session: Session):
        super().__init__()
        self.setObjectName("verdictBanner")
        self.session = session
        self.word = QLabel()
        self.word.setObjectName("verdictWord")
        self.detail = QLabel()
        self.detail.setWordWrap(True)
        # The verdict above its reasons and statistics: the banner heads the window's left
        # column (qa_app/desktop/docks.py).
        self.setMinimumHeight(60)
        lay = QVBoxLayout(self)
        lay.setContentsMargins(12, 6, 12, 8)
        lay.setSpacing(2)
        lay.addWidget(self.word)
        lay.addWidget(self.detail, 1)
        session.result_changed.connect(self.update_from)
        session.step_changed.connect(lambda step: self.update_from(session.run, step))
        self.update_from(None)

    def update_from(self, run, step=None) -> None:
        """verdict : the verdict shown (None when none is: no result, or a stale one);
        stale : the result shown is out of date."""
        self.stale = False
        self.trust_note = ""
        self.detail.setToolTip("")
        self.setToolTip("")
        if run is None:
            text = step.value if step is not None else "Open the nominal and the measured points"
            self.setStyleSheet("#verdictBanner { background: #e9edf2; border-radius: 4px; }")
            self.word.setText(f"<span style='font-size:15pt; color:#445'>{text}</span>")
            self.detail.setText("")
            self.verdict = None
            return
        res = run.result
        st = res.statistics
        tol = res.tolerance
        cond = res.conditioning
        trust, statements = pose_trust(res)
        stable = res.pose_sensitivity is None or res.pose_sensitivity.verdict_stable
        pose = ("pose ±" + f"{cond.pose_sigma_mm:.4f} mm" if cond is not None and
                cond.pose_sigma_mm is not None else
                "" if trust else "pose not fully constrained")
        n_excluded = int(res.outlier.sum())
        excluded = (f" · {n_excluded} excluded from alignment (gross outlier"
                    f"{'s' if n_excluded > 1 else ''})" if n_excluded else "")
        planned = getattr(res, "plan", None)
        facts = (
            plan_line(planned, run) +
            f"{st.count} points · {st.n_out} out of tolerance · zone {tol.lower:+.3f} … "
            f"{tol.upper:+.3f} mm"
            + (" (the plan's widest profile: statistics only)" if planned is not None
               and not planned.zone_in_verdict else "")
            + f"{excluded}<br>min {st.min:+.4f} · "
            f"max {st.max:+.4f} · mean {st.mean:+.4f} · std {st.std:.4f} · rms {st.rms:.4f} · "
            f"max |d| {st.max_abs:.4f} mm<br>fit {res.fit} · decision rule {res.decision_rule} · "
            f"registration rms {res.registration.rms:.4f} mm"
            + "".join(f" · {t}" for t in (pose, trust if stable else f"<b>{trust}</b>") if t))
        # The plain-word trust statements are the details behind the note (the certificate
        # states them in full); the banner keeps the verdict's own reasons.
        reasons_shown = [r for r in res.reasons if r not in statements]
        self.trust_note = trust
        details = "\n".join(s[:1].upper() + s[1:] + "." for s in statements)
        self.detail.setToolTip(details)
        self.setToolTip(details)  # anywhere on the banner
        reasons = self.session.stale_reasons if run is self.session.run else []
        if reasons:
            # No verdict is stated for a result that no longer matches the files and settings:
            # the old one stays readable, greyed, below what changed.
            self.stale = True
            self.verdict = None
            self.setStyleSheet("#verdictBanner { background: #d5d8dc; border: 2px solid #7a4b00;"
                               " border-radius: 4px; } QLabel { color: #3a3a44; }")
            self.word.setText(
                "<span style='font-size:22pt; font-weight:bold; color:#7a4b00'>OUT OF DATE"
                f"</span><br><span style='color:#8a8f96'>was "
                f"<s>{VERDICT_WORD[res.verdict]}</s></span>")
            self.detail.setText(
                f"<b>Changed since this inspection: {'; '.join(reasons)}. Press Inspect (F5) "
                f"for a result; export is disabled until then.</b><br>"
                f"<span style='color:#8a8f96'>{facts}</span>")
            return
        self.verdict = res.verdict
        colour = qcolor(VERDICT_RGB[res.verdict]).name()
        self.setStyleSheet(f"#verdictBanner {{ background: {colour}; "
                           "border-radius: 4px; } QLabel { color: white; }")
        self.word.setText(f"<span style='font-size:22pt; font-weight:bold'>"
                          f"{VERDICT_WORD[res.verdict]}</span>")
        self.detail.setText(f"{'; '.join(reasons_shown)}<br>{facts}")


def plan_line(planned, run) -> str:
    """The banner's line on ``run``'s plan (with its line break), or "" without a plan."""
    if planned is None:
        return ""
    path = run.settings.plan
    n = len(planned.characteristics)
    counts = [sum(r.verdict == v for r in planned.characteristics)
              for v in (Verdict.REJECT, Verdict.INCONCLUSIVE)]
    return (f"plan {os.path.basename(path or '')}: {n} characteristic{'s' if n != 1 else ''}"
            f" · {counts[0]} out of tolerance"
            + (f" · {counts[1]} undecided" if counts[1] else "")
            + f" · alignment {planned.method}"
            + ("" if planned.alignment is None else
               " " + "|".join(d.label for d in planned.alignment.datums)) + "<br>")


def pose_trust(res) -> tuple[str, tuple[str, ...]]:
    """(note, statements): how far the verdict depends on the pose, compactly, for the banner,
    and engine.trust's plain-word statements behind it.

    A verdict that differs at some pose the measurement allows (weak or free directions, a
    nearly-as-good runner-up: ``res.pose_sensitivity``) "depends on the pose"; one that holds
    at all of them while the pose is not fully fixed gets a short note; a runner-up or a free
    direction alone is a fact, never a reason to call a standing verdict ambiguous.
    """
    sens = res.pose_sensitivity
    statements = tuple(res.trust_statements)
    if sens is None:  # the pose cannot be trusted at all: the reasons say why
        return "", statements
    if not sens.verdict_stable:
        return "verdict depends on the pose", statements
    if statements or res.ambiguous:  # (an exact symmetry of the part is no statement)
        return "pose not fully fixed — verdict holds, see details", statements
    return "", statements
