"""What ``qa-inspect`` shows of its own use: the examples and exit codes under each ``--help``,
and each subcommand's usage, shown with its usage errors."""

from __future__ import annotations

from engine.errors import QAError


class UsageError(QAError, ValueError):
    """The command line was used wrongly (exit code 64, EX_USAGE): a missing or contradictory
    option, not a problem in the files it names. ``command``: the subcommand whose usage is
    shown with the message (None: the one parsed, else all of them)."""

    def __init__(self, message: str, command: str | None = None):
        super().__init__(message)
        self.command = command


EXAMPLES = """examples:
  qa-inspect inspect nominal.csv measured.csv --tol 0.25 --json r.json --csv r.csv
  qa-inspect inspect nominal.xyz measured.csv --plan plan.toml --report cert.pdf \\
      --sign inspector.p12 --part-number SB-1020 --serial S-17
  qa-inspect inspect part.stp scan.ply --tol 0.1 --uncertainty 0.012
  qa-inspect inspect frame.dxf points.csv --tol-lower -0.1 --tol-upper 0.3
  qa-inspect inspect part.stp scan.ply --tol 0.1 --section z=120 --section x=40 --report c.pdf
  qa-inspect batch nominal.csv 'lot-0412/*.csv' --tol 0.15 --out results/lot-0412
  qa-inspect keygen --name "Ann Inspector" --out identity/
  qa-inspect verify cert.pdf --trust ca.pem --nominal nominal.csv --measured measured.csv
  qa-inspect faces part.stp --csv faces.csv
  qa-inspect plan part.qif --nominal part.stp --toml plan.toml"""


EXIT_CODES = """exit codes:
  0   ACCEPT: every point inside the tolerance zone (verify: the certificate is valid)
  1   REJECT: a point outside it (verify: the certificate is not valid)
  2   INCONCLUSIVE: the pose cannot be trusted, or the verdict differs at a pose the
      measurement allows, or (guarded rule) a point lies within its uncertainty of a limit,
      or the nominal and the measured points are a units' factor (10, 25.4, 304.8, 1000)
      apart in size (the message says what reads either file right, e.g. --units mm)
  64  usage error: missing or contradictory options, an output that is an input
  65  bad input data (the message names the file, the line and the problem)
  66  an input file does not exist
  70  internal error (no result is written)
  73  an output could not be written (none is)
  69  batch: the Dask scheduler cannot be reached, or has no worker
  130 interrupted
  batch: 0 every part ACCEPT, else 1 any REJECT, else 2 any INCONCLUSIVE, else 65 (ERRORs)"""


USAGES = {
    "inspect": """qa-inspect inspect NOMINAL MEASURED --tol T [--tol-lower L --tol-upper U]
                  [--plan PLAN.toml|PART.qif] [--json FILE|-] [--csv FILE|-]
                  [--qif FILE|-] [--quiet] [--layer NAME] [--units U] [--scale CHORD]
                  [--crop XMIN YMIN ZMIN XMAX YMAX ZMAX]
                  [--remove-plane [--remove-plane-distance MM]]
                  [--section AXIS=MM ... [--section-band MM]]
                  [--report FILE.pdf [--sign ID.p12 [--sign-pass-env VAR]] [--part-number …]]""",
    "batch": """qa-inspect batch NOMINAL MEASURED... (--tol T | --tol-lower L --tol-upper U |
                  --plan PLAN.toml) --out DIR [--layer NAME] [--units U] [--scale CHORD]
                  [--fit …] [--decision-rule …] [--crop …]
                  [--remove-plane [--remove-plane-distance MM]]
                  [--report [--sign ID.p12 --sign-pass-env VAR] [--part-number …]]
                  [--scheduler ADDRESS] [--workers N] [--quiet]""",
    "keygen": "qa-inspect keygen --name NAME [--organisation ORG] --out DIR [--pass-env VAR]",
    "verify": """qa-inspect verify CERTIFICATE.pdf --trust CA.pem [--nominal FILE --measured FILE
                  [--plan FILE]]""",
    "faces": "qa-inspect faces PART.stp [--csv FILE|-]",
    "plan": "qa-inspect plan SOURCE [--nominal PART.stp] [--toml OUT.toml]",
}
"""Each subcommand's usage, shown with its usage errors (continuation lines aligned for the
"usage: " before them)."""


USAGE = "usage: " + "\n       ".join([*USAGES.values(), "qa-inspect --version"])
"""Every subcommand's usage: shown when no subcommand was named, or a wrong one."""


def usage(command: str | None) -> str:
    """The usage shown with a usage error of ``command`` (None or unknown: all of them)."""
    return "usage: " + USAGES[command] if command in USAGES else USAGE
