"""A longer check of the resolved input's real formatting than tests/test_real_text.py runs.

    /opt/tmafm-venv/bin/python studies/real_text_campaign.py [--values 180000] [--seed 1]

Draws random doubles three ways (random bit patterns, decimals rounded to 1..16 places, and
m x 10^e with m of 1..16 digits, |e| < 300), and checks for each that tmafm_float_format's
shortest_text_padded gives exactly tmafm_text's real_text_padded's text (both through
tests/testcore.py: real_texts) and that this is Python's shortest correctly rounded es text of 2..17 digits
(tests/test_real_text.py's shortest_es).  Prints the count checked and the mismatches (the first
five in full); exits 1 on any mismatch.
"""

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from test_real_text import shortest_es, texts  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--values", type=int, default=180_000)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    third = args.values // 3
    values = list(rng.integers(0, 2**63 - 1, third, dtype=np.int64).view(np.float64))
    values += [round(float(x), int(k))
               for x, k in zip(10 ** rng.uniform(-30, 30, third), rng.integers(1, 17, third))]
    values += [float(f"{m}e{e}") for m, e in zip(rng.integers(1, 10 ** int(rng.integers(1, 17)), third),
                                                  rng.integers(-300, 300, third))]
    values = [float(v) for v in values if math.isfinite(v)]
    bad = 0
    for start in range(0, len(values), 20_000):
        chunk = values[start:start + 20_000]
        fast, slow = texts(chunk)
        for value, f, s in zip(chunk, fast, slow):
            if f != s or (value != 0 and f.strip() != shortest_es(value)):
                bad += 1
                if bad <= 5:
                    print(f"mismatch: {value!r}: fast {f!r}, real_text_padded {s!r}, "
                          f"Python {shortest_es(value)!r}")
    print(f"checked {len(values)} values (seed {args.seed}): {bad} mismatches")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
