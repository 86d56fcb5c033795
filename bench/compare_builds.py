#!/usr/bin/env python3
"""Times vision_bench cases of two or more builds on a noisy machine.

Runs each binary in turn, again and again (interleaved, so a slow minute
hits all of them alike), and prints the fastest and the median real time of
each case per binary. Usage:

    bench/compare_builds.py FILTER ROUNDS NAME=BINARY [NAME=BINARY ...]

e.g. bench/compare_builds.py 'SphereDetectorLab|Shot200Lab' 8 \\
         before=/tmp/vision_bench_old now=build/bench/vision_bench
"""
import collections
import json
import subprocess
import sys


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    pattern, rounds = sys.argv[1], int(sys.argv[2])
    builds = [arg.split("=", 1) for arg in sys.argv[3:]]
    times = collections.defaultdict(list)
    for _ in range(rounds):
        for name, binary in builds:
            out = subprocess.run(
                [binary, f"--benchmark_filter={pattern}", "--benchmark_min_time=0.5",
                 "--benchmark_format=json"],
                capture_output=True, text=True, check=True).stdout
            for case in json.loads(out)["benchmarks"]:
                times[(case["name"], name)].append((case["real_time"], case["time_unit"]))
    for (case, name), values in sorted(times.items()):
        values.sort()
        unit = values[0][1]
        print(f"{case:24} {name:10} fastest {values[0][0]:9.1f} {unit}"
              f"  median {values[len(values) // 2][0]:9.1f} {unit}")


if __name__ == "__main__":
    main()
