"""Native readers run in a child process: a reader that trusts offsets and sizes inside the file
(VTK's, libE57Format's) can crash on a damaged one, which here becomes an InputError instead of
the end of the program. The child (``python -m <module> PATH ... OUT``) writes plain arrays to
OUT (.npz) and exits 0, or prints the problem and exits ``CHILD_INPUT_ERROR``."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile

import numpy as np

from ..errors import InputError

CHILD_INPUT_ERROR = 3
"""The child's exit code for a file it refused (its message on stdout)."""


def arrays_from_child(module: str, path: str, args: list[str], reader: str, damaged: str,
                      timeout_s: float) -> dict:
    """The arrays that ``python -m module path *args OUT`` writes to OUT, read back here.
    ``reader`` names the reader in messages ("VTK's reader"); ``damaged`` is the message of a
    refusal that printed none. Raises InputError on a refusal, a crash or a timeout."""
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    env = dict(os.environ, PYTHONPATH=root + os.pathsep + os.environ.get("PYTHONPATH", ""))
    with tempfile.TemporaryDirectory(prefix="qa-child-") as tmp:
        out = os.path.join(tmp, "arrays.npz")
        try:
            r = subprocess.run([sys.executable, "-m", module, path, *args, out],
                               capture_output=True, text=True, env=env, timeout=timeout_s)
        except subprocess.TimeoutExpired:
            raise InputError(f"{reader} did not finish within {timeout_s:g} s "
                             "(damaged file?)", path) from None
        if r.returncode == CHILD_INPUT_ERROR:
            raise InputError(r.stdout.strip() or damaged, path)
        if r.returncode != 0:
            how = f"signal {-r.returncode}" if r.returncode < 0 else f"exit {r.returncode}"
            raise InputError(f"damaged: {reader} crashed reading it ({how})", path)
        with np.load(out, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
