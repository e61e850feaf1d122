# The probes of bench_ppe_difficulty by phase of the obstacle dam break: means over the probes in each interval
# of T (at the step's start; T in (lo, hi]), per start of the probed system; steps.csv: every step's first
# solve. r0 as the geometric mean of |b - A x0| / |b|. Run in this folder: /usr/bin/python3 phases.py
import warnings

import numpy as np

warnings.simplefilter("ignore", RuntimeWarning)  # the ILU(0) run has no "previous" start: nan means

starts = ['warm', 'zero', 'parent', 'previous']
for s in ['jacobi', 'ilu0']:
    d = np.genfromtxt(f'probes_{s}.csv', delimiter=',', names=True)
    cols = [f'{k}_{st}' for st in starts for k in ['jacobi', 'ilu0']]
    bad = sum(int((d[c] < 0).sum()) for c in cols)
    print(f'run with {s}: {len(d)} probes, {bad} probe solves not converged, the previous start at '
          f'{int((d["mapped"] >= 0).sum())} of them')
    print('  T          probes unknowns | r0: warm zero parent previous | Jacobi: warm zero parent previous '
          '| ILU(0): warm zero parent previous')
    for lo, hi in [(0, 0.6), (0.6, 1.5), (1.5, 2.5), (2.5, 3.0), (3.0, 3.81), (0, 3.81)]:
        m = (d['T'] > lo) & (d['T'] <= hi)
        mp = m & (d['mapped'] >= 0)

        def mean(c, st):
            sel = mp if st == 'previous' else m
            return d[f'{c}_{st}'][sel].mean()
        r0 = ' '.join(f"{10 ** np.log10(d[f'r0_{st}'][mp if st == 'previous' else m]).mean():6.3g}"
                      for st in starts)
        jac = ' '.join(f'{mean("jacobi", st):6.1f}' for st in starts)
        ilu = ' '.join(f'{mean("ilu0", st):5.1f}' for st in starts)
        print(f"  ({lo}, {hi}] {m.sum():4d} {d['unknowns'][m].mean():6.0f} | {r0} | {jac} | {ilu}")
    st = np.genfromtxt(f'steps_{s}.csv', delimiter=',', names=True)
    for lo, hi in [(0, 0.6), (0.6, 3.81)]:
        m = (st['T'] >= lo) & (st['T'] < hi)
        print(f"  every step starting in [{lo}, {hi}): {m.sum()} steps, first solve "
              f"{st['first_solve_iterations'][m].mean():.1f} iterations, {st['repeat_solves'][m].mean():.2f} "
              f"repeats per step")
