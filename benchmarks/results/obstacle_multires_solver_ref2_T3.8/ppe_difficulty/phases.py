# The probes of bench_ppe_difficulty by phase of the obstacle dam break (means over the probes in each interval
# of T; steps.csv: the first solves of every step). Run in this folder: /usr/bin/python3 phases.py
import numpy as np

for s in ['jacobi', 'ilu0']:
    d = np.genfromtxt(f'probes_{s}.csv', delimiter=',', names=True)
    bad = sum(int((d[c] < 0).sum()) for c in ['jacobi_warm', 'jacobi_zero', 'ilu0_warm', 'ilu0_zero'])
    print(f'run with {s}: {len(d)} probes, {bad} probe solves not converged')
    print('  T interval  | probes | unknowns | mean log10 r0 | Jacobi from x0 / from 0 | ILU(0) from x0 / from 0')
    for lo, hi in [(0, 0.6), (0.6, 1.5), (1.5, 2.5), (2.5, 3.0), (3.0, 3.81)]:
        m = (d['T'] > lo) & (d['T'] <= hi)
        print(f"  ({lo}, {hi}] | {m.sum():3d} | {d['unknowns'][m].mean():5.0f} | {np.log10(d['r0'][m]).mean():5.2f} | "
              f"{d['jacobi_warm'][m].mean():6.1f} / {d['jacobi_zero'][m].mean():6.1f} | "
              f"{d['ilu0_warm'][m].mean():5.1f} / {d['ilu0_zero'][m].mean():5.1f}")
    st = np.genfromtxt(f'steps_{s}.csv', delimiter=',', names=True)
    for lo, hi in [(0, 0.6), (0.6, 3.81)]:
        m = (st['T'] > lo) & (st['T'] <= hi)
        print(f"  every step, T in ({lo}, {hi}]: {m.sum()} steps, first solve {st['first_solve_iterations'][m].mean():.1f} "
              f"iterations, {st['repeat_solves'][m].mean():.2f} repeats per step")
