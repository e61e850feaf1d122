#!/usr/bin/env python3
"""Front errors of two report_obstacle_multires studies against each other's references.

Two `--series` directories of benchmarks/report_obstacle_multires.cpp (e.g. the same study with --solver jacobi
and --solver ilu0) each hold their runs' fronts and their own reference. This prints every run of both
directories against both references, as the reporter's front_rms and body_front_rms, so that what a setting
changes in the reference is told apart from what it changes in the runs. As cases::compare_fronts
(examples/cases/tanaka_obstacle_multires.hpp): at each reference sample T inside the run's sampled interval and
T <= T_limit, the run's front linear between its two samples around T, e = |Z/Z_ref - 1|, non-finite e skipped;
RMS of e; runs with fewer than two samples compare nothing. T_limit is the reference's far-wall impact as the
reporter takes it: the first probe sample with a value (the probe wet), t* = t sqrt(2 g / a) with the case's
g = 9.8 m/s^2 and column width a = 0.1 m (cases::tanaka_dam_break_config); the reporter prints it ("wet at T").

  /usr/bin/python3 benchmarks/cross_fronts.py DIR_A DIR_B [REFERENCE_FILE]

REFERENCE_FILE defaults to single_2_mm.txt (--reference 2). Needs numpy.
"""
import bisect
import math
import os
import sys

import numpy as np

G, COLUMN_WIDTH = 9.8, 0.1


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


def impact_time(ref):
    """T of the reference's first wet probe sample (infinity when it never gets wet)."""
    wet = [t for t, p in ref['probe'] if math.isfinite(p)]
    return wet[0] * math.sqrt(2.0 * G / COLUMN_WIDTH) if wet else math.inf


def rms(run, ref, t_limit, series):
    t, z = list(run[series][:, 0]), list(run[series][:, 1])
    e = []
    if len(t) >= 2:
        for tr, zr in ref[series]:
            if tr < t[0] or tr > t[-1] or tr > t_limit:
                continue
            j = min(max(bisect.bisect_right(t, tr), 1), len(t) - 1)  # std::upper_bound, clamped to [1, n - 1]
            a = (tr - t[j - 1]) / (t[j] - t[j - 1])
            x = abs(((1.0 - a) * z[j - 1] + a * z[j]) / zr - 1.0)
            if math.isfinite(x):
                e.append(x)
    return (100.0 * math.sqrt(sum(x * x for x in e) / len(e)) if e else float('nan')), len(e)


def main(argv):
    if len(argv) not in (3, 4) or os.path.realpath(argv[1]) == os.path.realpath(argv[2]):
        sys.exit(__doc__)
    dirs = argv[1:3]
    ref_file = argv[3] if len(argv) == 4 else 'single_2_mm.txt'
    runs = sorted(r for r in set(os.listdir(dirs[0])) & set(os.listdir(dirs[1])) if r.endswith('.txt'))
    data = [{r: load(os.path.join(d, r)) for r in runs} for d in dirs]
    for series, name in (('front', 'front_rms'), ('front_body', 'body_front_rms')):
        for k, ref_dir in enumerate(dirs):
            ref = data[k][ref_file]
            t_limit = impact_time(ref)
            print(f'{name} (%) against {os.path.join(ref_dir, ref_file)}, T <= {t_limit:.6g}:')
            for r in runs:
                cells = []
                for d, dd in zip(dirs, data):
                    v, n = rms(dd[r], ref, t_limit, series)
                    cells.append(f'{os.path.basename(os.path.normpath(d))}: {v:6.2f} ({n} samples)')
                print(f'  {r[:-4]:24s} ' + '   '.join(cells))


if __name__ == '__main__':
    main(sys.argv)
