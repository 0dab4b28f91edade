"""Instructions per period of a basin map's runs in the core, for comparing two builds under
callgrind (CPU time is too noisy on a shared machine).  64 states of the Fig. 4 scene (an
8 x 8 grid of the benchmark's a1(0) x a1'(0) box), flight_exact at rtol 1e-8, one thread, no
known attractors: the same 1595 periods in both builds.

`run` observes them (`new`: observe_states with no observables, as tmafm.basin does; `old`:
observe_batch on 64 Configs with every observable, as tmafm.basin did before
observe_states); `none` only imports and builds the inputs.  (run - none) / periods is the
cost per period.  To compare with the commit before this benchmark (e9a82f9):

    git archive e9a82f9 | tar -x -C /tmp/old-src
    python -m pip install --no-build-isolation --no-deps --target /tmp/old-site /tmp/old-src
    for s in none run; do
      PYTHONPATH=/tmp/old-site valgrind --tool=callgrind --callgrind-out-file=old.$s.out \\
          python benchmarks/basin_core_instructions.py $s old
      valgrind --tool=callgrind --callgrind-out-file=new.$s.out \\
          python benchmarks/basin_core_instructions.py $s new
    done                                   # 'Collected' in each log: the instructions
"""

import importlib
import sys

import numpy as np

import tmafm

fig4 = tmafm.Config("fig4a", solver={"method": "flight_exact", "rtol": 1e-8})
n = 8
a1 = np.linspace(-1e-3, 1e-3, n)
adot1 = np.linspace(-2e-3, 2e-3, n)
states = np.zeros((n * n, 6))
states[:, 0] = np.repeat(a1, n)
states[:, 3] = np.tile(adot1, n)
configs = [tmafm.Config(fig4, initial={"a0": s[:3].tolist(), "adot0": s[3:].tolist()})
           for s in states]
if sys.argv[1] == "run":
    if sys.argv[2] == "old":
        out = tmafm.observe_batch(configs, threads=1)
        print("periods", sum(o.periods for o in out))
    else:
        observe = importlib.import_module("tmafm.observe")
        out = observe.observe_states(fig4, states, threads=1, observables=())
        print("periods", int(out.periods.sum()))
