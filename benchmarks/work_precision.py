"""Regenerate benchmarks/work_precision.json and .png (several minutes on 2 cores).

    /opt/tmafm-venv/bin/python benchmarks/work_precision.py [--quick]

A thin wrapper over ``python -m tmafm.workprecision`` run from the repository root.
"""

import sys
from pathlib import Path

import tmafm
from tmafm.workprecision import main

REPO = Path(__file__).resolve().parent.parent

if __name__ == "__main__":
    main(["--out", str(REPO / "benchmarks"), "--inputs", str(tmafm.inputs.folder()), *sys.argv[1:]])
