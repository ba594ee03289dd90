"""Throughput of the Python module's batch calls: points per second of one
call on N points, per CPU-second of the process (all its threads; the
per-core rate) and per wall-clock second, best of three.  Needs a table file
with an isotropic table of angles only, e.g. the `brdf_direct` table of
examples/mitsuba/oren-nayar-sphere.toml:

    build/brdftab generate examples/mitsuba/oren-nayar-sphere.toml -o on.h5
    PYTHONPATH=build/python python3 python/tools/bench_batch.py on.h5 brdf_direct [N] [THREADS]

The points are Weyl sequences (coordinate j of point k: frac((k + 1) a_j),
a_j the fractional part of the square root of the j-th prime), the same as
python/tools/bench_batch_cpp.cpp, which times the library's batch calls on
them in C++: the ratio of the two rates is the module's overhead per call.
"""
import math
import sys
import time

import numpy as np

import brdftab


def main(path, name, n, threads):
    brdftab.set_threads(threads)
    table = brdftab.open(path).tables[name]
    k1 = np.arange(1, n + 1, dtype=np.float64)

    def weyl(j):
        a = math.sqrt([2, 3, 5, 7, 11, 13, 17, 19][j])
        x = k1 * (a - math.floor(a))
        return x - np.floor(x)
    coords = {a.name: a.min + (a.max - a.min) * weyl(j) for j, a in enumerate(table.axes)}
    bound = table.bind()

    def directions(theta, phi):
        t, p = theta * (math.pi / 180), phi * (math.pi / 180)
        return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=1)
    wi = directions(85 * weyl(3), np.zeros(n))
    wo = directions(90 * weyl(4), 360 * weyl(5))
    u = np.stack([weyl(6), weyl(7)], axis=1)
    calls = {
        "Table.eval(coords), linear": lambda: table.eval(**coords),
        "BoundTable.eval(wi, wo)": lambda: bound.eval(wi, wo),
        "BoundTable.pdf(wi, wo)": lambda: bound.pdf(wi, wo),
        "BoundTable.sample(wi, u)": lambda: bound.sample(wi, u),
    }
    print(f"{path} table {name}, {n} points per call, {brdftab.threads()} thread(s)")
    for label, call in calls.items():
        cpu, wall = [], []
        for _ in range(3):
            c, w = time.process_time(), time.perf_counter()
            call()
            cpu.append(time.process_time() - c)
            wall.append(time.perf_counter() - w)
        print(f"  {label:28s} {n / min(cpu) / 1e6:6.2f} M/s per CPU-second, "
              f"{n / min(wall) / 1e6:6.2f} M/s wall")


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]) if len(sys.argv) > 3 else 1_000_000,
         int(sys.argv[4]) if len(sys.argv) > 4 else 0)
