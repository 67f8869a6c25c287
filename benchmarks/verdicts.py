"""The closing printout of the benchmarks that check targets: one verdict per target, then
one JSON line per case.

Each row is a dict with a ``"case"`` name and ``"targets"``, a list of dicts with
``"target"`` (what is measured), ``"value"``, ``"bound"`` and ``"pass"``.
"""

from __future__ import annotations

import json

import numpy as np


def print_verdicts(rows, case_width, target_width, bound_format):
    """Print a PASS/FAIL line per target of every row (bounds in ``bound_format``, e.g.
    ``"8.3f"``), then every row as a JSON line.
    """
    bound_width = int(bound_format.split(".")[0])
    print(f"\n{'case':{case_width}s} {'target':{target_width}s} {'value':>8s} {'bound':>{bound_width}s}  verdict")
    for row in rows:
        for t in row["targets"]:
            verdict = "PASS" if t["pass"] else "FAIL"
            line = f"{row['case']:{case_width}s} {t['target']:{target_width}s} {t['value']:8.3f}"
            print(f"{line} {t['bound']:{bound_format}}  {verdict}")
    print()
    for row in rows:
        print(json.dumps(row, default=lambda v: v.item() if isinstance(v, np.generic) else str(v)))
