#!/usr/bin/env python3
"""Front errors of two report_obstacle_multires studies against each other's references.

Two `--series` directories of benchmarks/report_obstacle_multires.cpp (e.g. the same study with --solver jacobi
and --solver ilu0) each hold their runs' fronts and their own reference. This prints every run of both
directories against both references, as the reporter's front_rms and body_front_rms (cases::compare_fronts: the
run's front, linear between its samples, at the reference's samples up to T_limit, RMS of |Z/Z_ref - 1|), so that
what a setting changes in the reference is told apart from what it changes in the runs. T_limit is the reference's
first wet sample at the far-wall probe, as the reporter prints it ("wet at T = ...").

  /usr/bin/python3 benchmarks/cross_fronts.py DIR_A T_LIMIT_A DIR_B T_LIMIT_B [REFERENCE_FILE]

REFERENCE_FILE defaults to single_2_mm.txt (--reference 2). Needs numpy.
"""
import math
import os
import sys

import numpy as np


def load(path):
    """The series of one run file (run_cache::save): front, probe and front_body as n x 2 arrays."""
    lines = open(path).read().split('\n')
    out, i = {}, 0
    while i < len(lines):
        w = lines[i].split()
        if w and w[0] in ('front', 'probe', 'front_body'):
            n = int(w[1])
            out[w[0]] = np.array([[float(v) for v in lines[i + 1 + k].split()] for k in range(n)]).reshape(n, 2)
            i += n + 1
        else:
            i += 1
    return out


def rms(run, ref, t_limit, series):
    t, z = run[series][:, 0], run[series][:, 1]
    e = [abs(np.interp(tr, t, z) / zr - 1.0) for tr, zr in ref[series]
         if t[0] <= tr <= t[-1] and tr <= t_limit]
    e = [x for x in e if math.isfinite(x)]
    return (100.0 * math.sqrt(sum(x * x for x in e) / len(e)) if e else float('nan')), len(e)


def main(argv):
    if len(argv) not in (5, 6):
        sys.exit(__doc__)
    dirs = {argv[1]: float(argv[2]), argv[3]: float(argv[4])}
    ref_file = argv[5] if len(argv) == 6 else 'single_2_mm.txt'
    runs = sorted(set(os.listdir(argv[1])) & set(os.listdir(argv[3])))
    runs = [r for r in runs if r.endswith('.txt')]
    data = {d: {r: load(os.path.join(d, r)) for r in runs} for d in dirs}
    for series, name in (('front', 'front_rms'), ('front_body', 'body_front_rms')):
        for ref_dir, t_limit in dirs.items():
            print(f'{name} (%) against {os.path.join(ref_dir, ref_file)}, T <= {t_limit}:')
            ref = data[ref_dir][ref_file]
            for r in runs:
                cells = []
                for d in dirs:
                    v, n = rms(data[d][r], ref, t_limit, series)
                    cells.append(f'{v:6.2f} ({n} samples)')
                print(f'  {r[:-4]:24s} ' + '   '.join(f'{os.path.basename(os.path.normpath(d))}: {c}'
                                                      for d, c in zip(dirs, cells)))


if __name__ == '__main__':
    main(sys.argv)
