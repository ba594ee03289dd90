"""brdftab tables from Python.

Open a table file written by ``brdftab generate``, interpolate its tables at
numpy arrays of coordinates (in each axis' warped coordinate, exactly as the
C++ library and ``brdftab query`` do), evaluate and importance-sample a table
bound to fixed parameters with direction vectors.  Reference: docs/python.md.

    import brdftab
    f = brdftab.open("oren-nayar-brdf.h5")
    brdf = f.tables["brdf"]
    brdf.eval(theta_i=30, theta_o=[10, 20, 40], phi_d=90, sigma=20, rho=0.8)
    bsdf = brdf.bind(sigma=20, rho=0.8)
    wo, weight, pdf = bsdf.sample(wi, u)
"""

import warnings
from collections.abc import Mapping

import numpy as np

from . import _brdftab
from ._brdftab import Axis, Error, InputError, set_threads, threads

__all__ = ["open", "File", "Table", "BoundTable", "Axis", "Error", "InputError", "to_xarray",
           "set_threads", "threads"]


def _columns(coords, order, names):
    """The coordinate arrays as float64 columns in the library's order, each
    of the broadcast size or of one value (shared by every point, not
    copied); returns (columns, point count, broadcast shape)."""
    arrays = [np.asarray(coords[n], dtype=np.float64) for n in names]
    shape = np.broadcast_shapes(*(a.shape for a in arrays)) if arrays else ()
    n = int(np.prod(shape)) if shape else 1
    columns = []
    for i in order:
        a = arrays[i]
        if a.size == 1:
            columns.append(a.reshape(1))
        elif a.shape == shape:
            columns.append(a.reshape(-1))
        else:
            columns.append(np.broadcast_to(a, shape).reshape(-1))
    return columns, n, shape


def _warn_clamped(clamped, points):
    """One RuntimeWarning per call for the coordinates the lookup clamped
    (as `brdftab query` warns; out_of_range="reject" makes them an error)."""
    if not clamped:
        return
    parts = []
    for name, count, first, lo, hi in clamped:
        where = "" if points == 1 else f" at {count} of {points} points (first {first:g})"
        value = f" = {first:g}" if points == 1 else ""
        parts.append(f"{name}{value} is outside [{lo:g}, {hi:g}]{where}")
    warnings.warn("; ".join(parts) + ", clamped (out_of_range='reject' makes this an error)",
                  RuntimeWarning, stacklevel=4)


def _shaped(values, shape):
    return float(values[0]) if shape == () else values.reshape(shape)


def _directions(w, what):
    a = np.asarray(w, dtype=np.float64)
    if a.shape[-1:] != (3,):
        raise InputError(f"{what}: expected direction vectors of shape (..., 3), got {a.shape}")
    return a


class Table:
    """One table of a file: metadata, axes, stored values, interpolation.

    Coordinates are given by name in the axes' user units (degrees for
    angles), plus the recombination parameter of a recombined table (e.g.
    ``rho`` for Oren-Nayar).  Each may be a number or an array; arrays
    broadcast against each other as in numpy."""

    def __init__(self, path, name):
        # An adaptive table (docs/adaptive.md): eval(), eval_stderr() and
        # bind() as for a tensor table, linear only; values is one number
        # per stored node.
        if _brdftab._is_adaptive(str(path), name):
            self._t = _brdftab._AdaptiveTable(str(path), name)
        else:
            self._t = _brdftab._Table(path, name)

    representation = property(
        lambda self: "adaptive" if isinstance(self._t, _brdftab._AdaptiveTable) else "tensor",
        doc="'tensor' or 'adaptive' (docs/adaptive.md)")

    # --- metadata -------------------------------------------------------
    path = property(lambda self: self._t.path)
    name = property(lambda self: self._t.name)
    model = property(lambda self: self._t.model)
    quantity = property(lambda self: self._t.quantity)
    units = property(lambda self: self._t.units)
    description = property(lambda self: self._t.description)
    parameters = property(lambda self: self._t.parameters,
                          doc="fixed model parameters and options (dict)")
    provenance = property(lambda self: self._t.provenance,
                          doc="method, samples, tolerance, seed, precision, device, version")
    axes = property(lambda self: self._t.axes, doc="list of Axis, outermost first")
    coordinate_names = property(lambda self: self._t.coordinate_names,
                                doc="names eval() expects: the axes, then the "
                                    "recombination parameter if any")
    values = property(lambda self: self._t.values,
                      doc="stored values, a read-only numpy view (no copy), shape of the axes "
                          "(an adaptive table: one value per stored node, 1-D)")
    stderr = property(lambda self: self._t.stderr,
                      doc="stored standard errors (read-only view) or None")
    certificate = property(lambda self: self._t.certificate,
                           doc="the stored certificate (dict: max_error, rms_error, measure, "
                               "abs_floor, interpolation, target, passed) or None: the measured "
                               "total error between nodes, which the stored stderr leaves out")

    @property
    def recombination(self):
        """The recipe of a recombined table (dict: parameter, terms, prefactor) or None."""
        return self.parameters.get("recombine") if self._t.has_recombination else None

    def __repr__(self):
        if self.representation == "adaptive":
            axes = (", ".join(a.name for a in self.axes) +
                    f", adaptive: {self._t.leaf_count} patches, {len(self.values)} values")
        else:
            axes = ", ".join(f"{a.name}[{a.count}]" for a in self.axes)
        c = self.certificate
        if c is not None:
            accuracy = (f"; certified max total error {c['max_error']:.3g} {c['measure']} "
                        f"({c['interpolation']} interpolation)")
        elif self._t.has_stderr:
            accuracy = "; no certificate: the stored stderr leaves out the interpolation error"
        else:
            accuracy = ""
        return (f"<brdftab.Table '{self.name}': {self.model} / {self.quantity} [{self.units}], "
                f"{axes}{accuracy}>")

    # --- interpolation --------------------------------------------------
    def _eval(self, coords, interpolation, out_of_range, of_stderr):
        names = list(coords)
        order = self._t._order(names)
        columns, n, shape = _columns(coords, order, names)
        values, clamped = self._t._eval_columns(columns, n, interpolation, out_of_range, of_stderr)
        _warn_clamped(clamped, n)
        return _shaped(values, shape)

    def eval(self, interpolation="linear", out_of_range="clamp", **coords):
        """Interpolated value(s). interpolation: 'linear' (multilinear) or
        'cubic' (Catmull-Rom), in each axis' warped coordinate;
        out_of_range: 'clamp' (a RuntimeWarning, once per call, names the
        clamped coordinates) or 'reject' (InputError naming the axis and its
        range).  A float when every coordinate is a number, else an array of
        the broadcast shape."""
        return self._eval(coords, interpolation, out_of_range, False)

    def eval_stderr(self, interpolation="linear", out_of_range="clamp", **coords):
        """The stored standard error, interpolated like eval() (as
        `brdftab query` prints it): the integration noise at the nodes, not
        the error between them (see ``certificate``).  InputError when the
        table stores none."""
        return self._eval(coords, interpolation, out_of_range, True)

    def bind(self, interpolation="linear", out_of_range="clamp", **params):
        """Fix every non-angle coordinate; returns a BoundTable over direction
        pairs (isotropic tables with theta_i|mu_i, theta_o|mu_o, optional phi_d).
        A clamped parameter warns (RuntimeWarning) as eval() does."""
        bound = BoundTable(self, self._t._bind(params, interpolation, out_of_range), params)
        if out_of_range == "clamp":
            clamped = [(a.name, 1, float(params[a.name]), a.min, a.max) for a in self.axes
                       if a.name in params and not
                       (a.min - 1e-9 * (a.max - a.min) <= float(params[a.name]) <= a.max + 1e-9 * (a.max - a.min))]
            _warn_clamped(clamped, 1)
        return bound


class BoundTable:
    """A table with its parameters fixed: eval / sample / pdf on direction
    vectors (z = macro normal, both pointing away from the surface), arrays of
    shape (..., 3).  Uses the interpolation given to bind()."""

    def __init__(self, table, bound, params):
        self.table = table
        self.params = dict(params)
        self._b = bound

    can_sample = property(lambda self: self._b.can_sample)
    sampling_error = property(lambda self: self._b.sampling_error)

    def _pair(self, a, b, what_a, what_b, width_b=3):
        a = _directions(a, what_a)
        b = np.asarray(b, dtype=np.float64)
        if b.shape[-1:] != (width_b,):
            raise InputError(f"{what_b}: expected shape (..., {width_b}), got {b.shape}")
        shape = np.broadcast_shapes(a.shape[:-1], b.shape[:-1])
        a = np.ascontiguousarray(np.broadcast_to(a, shape + (3,)).reshape(-1, 3))
        b = np.ascontiguousarray(np.broadcast_to(b, shape + (width_b,)).reshape(-1, width_b))
        return a, b, shape

    def eval(self, wi, wo):
        """f(wi, wo) (the table value, without any cosine)."""
        wi, wo, shape = self._pair(wi, wo, "wi", "wo")
        return _shaped(self._b._eval(wi, wo), shape)

    def pdf(self, wi, wo):
        """Density (1/sr) with which sample() draws wo."""
        wi, wo, shape = self._pair(wi, wo, "wi", "wo")
        return _shaped(self._b._pdf(wi, wo), shape)

    def sample(self, wi, u):
        """Sample wo given wi from uniform numbers u (shape (..., 2), in [0, 1)).
        Returns (wo, weight, pdf): weight = f(wi, wo) |cos theta_o| / pdf."""
        wi, u, shape = self._pair(wi, u, "wi", "u", 2)
        wo, weight, pdf, _ = self._b._sample(wi, u)
        if shape == ():
            return wo[0], float(weight[0]), float(pdf[0])
        return wo.reshape(shape + (3,)), weight.reshape(shape), pdf.reshape(shape)


class _Tables(Mapping):
    """Tables of a file by name, each read on first access."""

    def __init__(self, path):
        self._path = path
        self._names = _brdftab.table_names(path)
        self._cache = {}

    def __getitem__(self, name):
        if name not in self._cache:
            if name not in self._names:
                # The library's message for a missing table.
                _brdftab._Table(self._path, name)
            self._cache[name] = Table(self._path, name)
        return self._cache[name]

    def __iter__(self):
        return iter(self._names)

    def __len__(self):
        return len(self._names)


class File:
    """A brdftab table file: ``.tables`` maps names to Table objects."""

    def __init__(self, path):
        self.path = str(path)
        self.tables = _Tables(self.path)

    @property
    def attributes(self):
        """File-level attributes (brdftab version, spec, creation time)."""
        return _brdftab.file_attributes(self.path)

    def __getitem__(self, name):
        return self.tables[name]

    def __repr__(self):
        return f"<brdftab.File '{self.path}': {', '.join(self.tables)}>"


def open(path):  # noqa: A001 (the module's entry point, as in h5py/xarray)
    """Open a table file written by `brdftab generate`.  InputError (with the
    message `brdftab query` prints) when it is missing or not a brdftab file."""
    return File(path)


def to_xarray(table):
    """The stored values of `table` as a labelled xarray.DataArray: one
    dimension per axis, its nodes as coordinates (with units and spacing in
    their attrs), the stored standard error (if any) as the coordinate
    ``stderr``, the metadata in ``attrs``.  xarray's own ``interp`` is linear
    in the axis value, not in the table's warped coordinate: use
    ``table.eval`` for brdftab's interpolation.  Needs xarray (ImportError
    otherwise)."""
    if table.representation == "adaptive":
        raise InputError(f"table '{table.name}' is adaptive: its values are patch nodes, not a "
                         "grid; use table.eval at the points wanted")
    import xarray as xr

    coords = {}
    for a in table.axes:
        coords[a.name] = xr.Variable(a.name, a.values,
                                     attrs={"units": a.unit, "spacing": a.spacing})
    attrs = {"name": table.name, "model": table.model, "quantity": table.quantity,
             "units": table.units, "description": table.description}
    da = xr.DataArray(np.asarray(table.values), dims=[a.name for a in table.axes],
                      coords=coords, name=table.name, attrs=attrs)
    if table.stderr is not None:
        da.coords["stderr"] = (da.dims, np.asarray(table.stderr))
    return da
