#!/usr/bin/env python3
"""Summary of a run of benchmarks/run_search.sh: per benchmark the median time per item over the
repetitions (wall clock; CPU time of the calling thread beside it for 1 thread), the min-max spread, and
ratios formed inside one run (mixed/uniform per pair, with/without reorder, hand loop/operator, 2/1
threads). Usage: summarize_search.py [--markdown] <results prefix> <thread counts...>
(--markdown: the tables of docs/performance.md)."""
import json
import statistics
import sys


def load(prefix, t):
    with open(f"{prefix}-t{t}.json") as f:
        data = json.load(f)
    runs = {}
    for b in data["benchmarks"]:
        if b.get("run_type") != "iteration":
            continue
        name = b["run_name"].replace("/real_time", "")
        per = b.get("per_pair", b.get("per_particle"))
        unit = "pair" if "per_pair" in b else "particle"
        cpu = per * b["cpu_time"] / b["real_time"]
        runs.setdefault(name, {"unit": unit, "real": [], "cpu": [], "ppp": b.get("pairs_per_particle")})
        runs[name]["real"].append(per * 1e9)
        runs[name]["cpu"].append(cpu * 1e9)
    return runs


def med(v):
    return statistics.median(v)


def markdown(res, threads):
    """One table per benchmark variant: rows n, columns per thread count."""
    groups = {}
    for name in res[threads[0]]:
        parts = name.split("/")
        variant = "/".join([parts[0]] + [p for p in parts[1:] if not p.startswith("n:")])
        n = next(p for p in parts if p.startswith("n:"))[2:]
        groups.setdefault(variant, []).append((int(n), name))
    for variant, rows in groups.items():
        unit = res[threads[0]][rows[0][1]]["unit"]
        print(f"\n**{variant}** (ns per {unit})\n")
        head = "| n | pairs/particle |"
        sep = "|---:|---:|"
        for t in threads:
            head += f" {t} thread{'s' if t != '1' else ''}: median [min–max] |"
            sep += "---:|"
            if t == "1":
                head += " 1 thread, CPU time |"
                sep += "---:|"
        print(head)
        print(sep)
        for n, name in sorted(rows):
            r0 = res[threads[0]][name]
            line = f"| {n:,} | {r0['ppp']:.1f} |" if r0["ppp"] else f"| {n:,} | – |"
            for t in threads:
                r = res[t].get(name)
                if r is None:
                    line += " – |"
                    continue
                line += f" {med(r['real']):.2f} [{min(r['real']):.2f}–{max(r['real']):.2f}] |"
                if t == "1":
                    line += f" {med(r['cpu']):.2f} |"
            print(line)


def main():
    if sys.argv[1] == "--markdown":
        prefix, threads = sys.argv[2], sys.argv[3:]
        markdown({t: load(prefix, t) for t in threads}, threads)
        return
    prefix, threads = sys.argv[1], sys.argv[2:]
    res = {t: load(prefix, t) for t in threads}
    print("## Summary: ns per item, median of repetitions [min-max]; cpu = CPU time of the main thread")
    names = list(res[threads[0]].keys())
    header = f"{'benchmark':52s} {'item':8s} {'pairs/p':>7s}"
    for t in threads:
        header += f" | {t} thr: median [min-max]"
        if t == "1":
            header += "  cpu"
    print(header)
    for n in names:
        r0 = res[threads[0]][n]
        line = f"{n:52s} {r0['unit']:8s} {r0['ppp'] if r0['ppp'] else 0:7.1f}"
        for t in threads:
            r = res[t].get(n)
            if r is None:
                line += " | -"
                continue
            line += f" | {med(r['real']):7.2f} [{min(r['real']):.2f}-{max(r['real']):.2f}]"
            if t == "1":
                line += f" {med(r['cpu']):6.2f}"
        print(line)

    print("\n## Ratios inside one run (median of per-repetition ratios is not used: ratio of medians)")
    for t in threads:
        r = res[t]

        class ratio:
            """Ratio of medians; for 1 thread printed as wall/CPU-time ratio."""

            def __init__(self, a, b):
                ok = a in r and b in r
                self.real = med(r[a]["real"]) / med(r[b]["real"]) if ok else float("nan")
                self.cpu = med(r[a]["cpu"]) / med(r[b]["cpu"]) if ok else float("nan")

            def __format__(self, spec):
                if t == "1":
                    return f"{self.real:{spec}} (cpu {self.cpu:{spec}})"
                return f"{self.real:{spec}}"

        for n in ("10000", "100000", "1000000"):
            for skin in ("0", "100"):
                print(f"{t} thr n={n:>7s} skin={skin:>3s}: mixed/uniform CSR build per pair = "
                      f"{ratio(f'csr_build_mixed/n:{n}/skin_permille:{skin}', f'csr_build/n:{n}/skin_permille:{skin}'):.2f}")
            print(f"{t} thr n={n:>7s}: cell build with/without reorder (cell order) = "
                  f"{ratio(f'cell_build/n:{n}/shuffled:0/reorder:1', f'cell_build/n:{n}/shuffled:0/reorder:0'):.2f}; "
                  f"sweep hand/op = {ratio(f'sweep/n:{n}/hand:1', f'sweep/n:{n}/hand:0'):.2f}; "
                  f"mixed/uniform sweep per pair = {ratio(f'sweep_mixed/n:{n}', f'sweep/n:{n}/hand:1'):.2f}; "
                  f"kd query / CSR build per pair = "
                  f"{ratio(f'kdtree_query/n:{n}', f'csr_build/n:{n}/skin_permille:0'):.2f}")
    if len(threads) > 1:
        a, b = threads[0], threads[-1]
        print(f"\n## Speed-up {b} threads / {a} thread (median wall time ratio, separate runs)")
        for n in names:
            if n in res[b]:
                print(f"{n:52s} {med(res[a][n]['real']) / med(res[b][n]['real']):.2f}")


if __name__ == "__main__":
    main()
