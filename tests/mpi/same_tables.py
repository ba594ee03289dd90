#!/usr/bin/env python3
"""same_tables.py A.h5 B.h5 [--timings-too]: exit 0 when the two brdftab
files hold the same tables: every dataset equal byte for byte (dtype, shape,
values), the same dimension scales, every attribute equal except the
timings: the file's `created` and each table's `elapsed_seconds` and
`certificate_seconds` (wall-clock times, different on every run).  Object references (DIMENSION_LIST,
REFERENCE_LIST) are compared through the scales they name."""
import sys
import h5py
import numpy as np

TIMINGS = {"created", "elapsed_seconds", "certificate_seconds"}


def main():
    a, b = h5py.File(sys.argv[1], "r"), h5py.File(sys.argv[2], "r")
    problems = []

    def attrs(x, y, where):
        if set(x.attrs) != set(y.attrs):
            problems.append(f"{where}: attribute names {sorted(x.attrs)} != {sorted(y.attrs)}")
        for k in set(x.attrs) & set(y.attrs):
            if k in TIMINGS or k in ("DIMENSION_LIST", "REFERENCE_LIST"):
                continue
            u, v = np.asarray(x.attrs[k]), np.asarray(y.attrs[k])
            same = u.dtype == v.dtype and u.shape == v.shape and (
                u.tolist() == v.tolist() if u.dtype.kind == "O" else u.tobytes() == v.tobytes())
            if not same:
                problems.append(f"{where}: attribute {k}: {x.attrs[k]!r} != {y.attrs[k]!r}")

    def walk(x, y, where):
        attrs(x, y, where)
        if set(x) != set(y):
            problems.append(f"{where}: members {sorted(x)} != {sorted(y)}")
        for k in sorted(set(x) & set(y)):
            if isinstance(x[k], h5py.Group):
                walk(x[k], y[k], f"{where}{k}/")
                continue
            u, v = x[k][()], y[k][()]
            if u.dtype != v.dtype or u.shape != v.shape or u.tobytes() != v.tobytes():
                problems.append(f"{where}{k}: values differ")
            if x[k].compression != y[k].compression or x[k].chunks != y[k].chunks or \
                    x[k].fletcher32 != y[k].fletcher32 or x[k].shuffle != y[k].shuffle:
                problems.append(f"{where}{k}: storage (chunks, filters) differs")
            attrs(x[k], y[k], f"{where}{k}")
            scales = lambda d: [[s.name for s in dim.values()] for dim in d.dims]
            if scales(x[k]) != scales(y[k]):
                problems.append(f"{where}{k}: dimension scales differ")

    walk(a, b, "/")
    if not [k for k in a if isinstance(a[k], h5py.Group)]:
        problems.append("no tables")
    for p in problems[:20]:
        print(f"{sys.argv[1]} vs {sys.argv[2]}: {p}")
    sys.exit(1 if problems else 0)


main()
