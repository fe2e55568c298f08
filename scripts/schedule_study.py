#!/usr/bin/python3
"""What a validate study costs on N ranks: simulated from measured case costs.

Reads the per-case costs of a `kcrig validate --timings FILE` run (case,
truth, seconds), draws studies of --cases cases from them (each case's cost
resampled from the measured cases of its truth, the truths cycling as
validate cycles them), and simulates each study on each rank count with
three schedules:

  static    rank r runs cases r, r+N, ... (round-robin: the design and
            diagnosis batches' schedule before)
  dynamic   the next case in index order to whichever rank is free
            (validate's schedule before)
  kcrig     kcrig's Distribute: the next case to whichever rank is free,
            truths not yet measured first, then the truth whose cases have
            taken longest on average so far

and prints the median and 95th-percentile wall time of each, with the
bound no schedule beats (the larger of total/N and the costliest case).

usage: schedule_study.py TIMINGS.csv [--cases 2000] [--ranks 16,64,256]
                         [--draws 200] [--seed 1]
"""
import argparse
import csv
import heapq
import math
import random
import statistics


def read_costs(path):
    by_truth, order = {}, []
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            truth, seconds = row["truth"], float(row["seconds"])
            if not math.isfinite(seconds) or seconds < 0:
                raise SystemExit(f"{path}: case {row['case']}: bad seconds")
            if truth not in by_truth:
                by_truth[truth] = []
                order.append(truth)
            by_truth[truth].append(seconds)
    if not order:
        raise SystemExit(f"{path}: no cases")
    return by_truth, order


def static(costs, truths, ranks):
    loads = [0.0] * ranks
    for i, cost in enumerate(costs):
        loads[i % ranks] += cost
    return max(loads)


def dynamic(costs, truths, ranks, adaptive):
    """Event simulation: a free rank takes the next case at once."""
    left = list(range(len(costs)))
    measured = {}  # truth -> [seconds, cases]
    free = [(0.0, r) for r in range(ranks)]  # (time free, rank)
    running = []  # (end, case)
    heapq.heapify(free)
    end = 0.0
    while left:
        now, rank = heapq.heappop(free)
        while running and running[0][0] <= now:  # cases that ended by now
            _, done = heapq.heappop(running)
            m = measured.setdefault(truths[done], [0.0, 0])
            m[0] += costs[done]
            m[1] += 1
        pick = 0
        if adaptive:
            def expected(case):
                m = measured.get(truths[case])
                return math.inf if m is None else m[0] / m[1]
            pick = max(range(len(left)), key=lambda k: (expected(left[k]), -k))
        case = left.pop(pick)
        finish = now + costs[case]
        heapq.heappush(running, (finish, case))
        heapq.heappush(free, (finish, rank))
        end = max(end, finish)
    return end


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("timings")
    parser.add_argument("--cases", type=int, default=2000)
    parser.add_argument("--ranks", default="16,64,256")
    parser.add_argument("--draws", type=int, default=200)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    by_truth, order = read_costs(args.timings)
    every = [s for t in order for s in by_truth[t]]
    print(f"measured: {len(every)} cases, {len(order)} truths; cost per case "
          f"median {statistics.median(every):.2f} s, mean "
          f"{statistics.mean(every):.2f} s, max {max(every):.2f} s")
    for truth in order:
        s = by_truth[truth]
        print(f"  {truth:22s} {len(s):3d} cases, mean {statistics.mean(s):6.2f}"
              f" s, max {max(s):6.2f} s")
    rng = random.Random(args.seed)
    print(f"\n{args.cases} cases, {args.draws} draws: wall time in minutes, "
          "median (95th percentile)")
    print(f"{'ranks':>6} {'bound':>14} {'static':>14} {'dynamic':>14} "
          f"{'kcrig':>14}")
    for ranks in [int(r) for r in args.ranks.split(",")]:
        rows = {"bound": [], "static": [], "dynamic": [], "kcrig": []}
        for _ in range(args.draws):
            truths = [order[i % len(order)] for i in range(args.cases)]
            costs = [rng.choice(by_truth[t]) for t in truths]
            rows["bound"].append(max(sum(costs) / ranks, max(costs)))
            rows["static"].append(static(costs, truths, ranks))
            rows["dynamic"].append(dynamic(costs, truths, ranks, False))
            rows["kcrig"].append(dynamic(costs, truths, ranks, True))
        cells = []
        for name in ("bound", "static", "dynamic", "kcrig"):
            v = sorted(rows[name])
            cells.append(f"{statistics.median(v) / 60:6.2f} "
                         f"({v[int(0.95 * (len(v) - 1))] / 60:5.2f})")
        print(f"{ranks:>6} " + " ".join(f"{c:>14}" for c in cells))


if __name__ == "__main__":
    main()
