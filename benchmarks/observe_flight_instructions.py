"""The core's instructions for one observed run of Fig. 2 with flight_exact (every observable,
32 periods, stop_at_steady=False, the default tolerances), counted by callgrind inside the
core's batch only (the interpreter's start-up and the imports are not counted):

    valgrind --tool=callgrind --toggle-collect='__tmafm_batch_MOD_observe_batch*' \\
        python benchmarks/observe_flight_instructions.py [N]      # 'Collected' in the log

N (default 4) is the number of modes.  To compare with another commit, install it into a
folder of its own and put that first on PYTHONPATH (benchmarks/basin_core_instructions.py).
"""

import sys

import tmafm

n = int(sys.argv[1]) if len(sys.argv) > 1 else 4
obs = tmafm.observe("fig2_n4", max_periods=32, stop_at_steady=False, solver={"method": "flight_exact"},
                    model={"n_modes": n}, initial={"a0": [0.0] * n, "adot0": [0.0] * n})
print("periods", obs.periods, "amplitude", obs.per_period["amplitude"][-1])
