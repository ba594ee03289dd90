// bindings.cpp — the Python extension `brdftab._brdftab`: the renderer-side
// library (host/lookup/lookup.h) and the table reader (host/io/table_io.h)
// over numpy arrays.  The user-facing API (keyword coordinates, broadcasting,
// the file object) is in python/brdftab/__init__.py; this file only moves
// arrays in and out and loops over points with the GIL released (the lookup
// objects are immutable, lookup.h "Thread safety").
//
// Library errors keep their messages: brdftab::InputError becomes
// brdftab.InputError (a ValueError), every other brdftab::Error
// brdftab.Error (a RuntimeError), so Python sees the text the CLI prints
// after "brdftab: error: ".
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "host/core/error.h"
#include "host/core/vocabulary.h"
#include "host/io/table_io.h"
#include "host/lookup/lookup.h"
#include "host/lookup/lookup_internal.h"

namespace py = pybind11;
using namespace brdftab;

namespace {

using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

py::object json_to_python(const nlohmann::json& j) {
    return py::module_::import("json").attr("loads")(j.dump());
}

Interpolation interpolation_of(const std::string& name) {
    if (name == "linear") return Interpolation::Linear;
    if (name == "cubic") return Interpolation::Cubic;
    throw InputError("interpolation must be 'linear' or 'cubic', got '" + name + "'");
}

OutOfRange out_of_range_of(const std::string& name) {
    if (name == "clamp") return OutOfRange::Clamp;
    if (name == "reject") return OutOfRange::Reject;
    throw InputError("out_of_range must be 'clamp' or 'reject', got '" + name + "'");
}

// A read-only numpy view of `data` (row-major, shape of the axes) that keeps
// `owner` alive.
py::array view(const std::vector<double>& data, const std::vector<Axis>& axes,
               py::handle owner) {
    std::vector<py::ssize_t> shape, strides(axes.size());
    for (const auto& a : axes) shape.push_back(py::ssize_t(a.count));
    py::ssize_t stride = sizeof(double);
    for (std::size_t d = axes.size(); d-- > 0;) {
        strides[d] = stride;
        stride *= shape[d];
    }
    py::array a(py::dtype::of<double>(), shape, strides, data.data(), owner);
    py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
    return a;
}

// An (n, width) float64 array, checked.
DoubleArray rows_of(const py::array& in, std::size_t width, const char* what) {
    DoubleArray a = DoubleArray::ensure(in);
    if (!a) throw InputError(std::string(what) + ": expected an array of numbers");
    if (a.ndim() != 2 || std::size_t(a.shape(1)) != width)
        throw InputError(std::string(what) + ": expected shape (n, " + std::to_string(width) +
                         ")");
    return a;
}

Vec3 vec_at(const DoubleArray& a, py::ssize_t k) {
    const double* p = a.data(k, 0);
    return {p[0], p[1], p[2]};
}

// The lookup table of one stored table, with its standard-error lookup.
struct PyTable {
    std::string path;
    std::shared_ptr<const LookupTable> lookup;
    std::shared_ptr<const LookupTable> stderr_table;  // null when none is stored

    PyTable(const std::string& file, const std::string& name)
        : path(file),
          lookup(std::make_shared<const LookupTable>(LookupTable::open(file, name))),
          stderr_table(stderr_lookup(*lookup)) {}

    py::array eval_rows(const py::array& points, const std::string& interp,
                        const std::string& mode, bool of_stderr) const {
        const LookupTable* lt = lookup.get();
        if (of_stderr) {
            lt = stderr_table.get();
            if (!lt)
                throw InputError("table '" + lookup->table().name +
                                 "' stores no standard errors (a closed form, a table "
                                 "written without them, or a recombined table)");
        }
        const DoubleArray rows = rows_of(points, lt->coordinate_names().size(), "coordinates");
        const Interpolation ip = interpolation_of(interp);
        const OutOfRange om = out_of_range_of(mode);
        py::array_t<double> out(rows.shape(0));
        double* dst = out.mutable_data();
        const double* src = rows.data();
        const std::size_t n = std::size_t(rows.shape(0));
        {
            py::gil_scoped_release release;
            lt->eval_many(src, n, dst, ip, om);
        }
        return out;
    }
};

struct PyBound {
    std::shared_ptr<const BoundTable> bound;
};

}  // namespace

PYBIND11_MODULE(_brdftab, m) {
    m.doc() = "brdftab tables from Python: interpolation, direction-level evaluation and "
              "importance sampling (the renderer-side library, host/lookup/lookup.h)";

    // Exceptions: Error(RuntimeError) and InputError(Error, ValueError).
    static py::handle error_type = PyErr_NewException("brdftab.Error", PyExc_RuntimeError, nullptr);
    py::tuple input_bases = py::make_tuple(error_type, py::handle(PyExc_ValueError));
    static py::handle input_error_type =
        PyErr_NewException("brdftab.InputError", input_bases.ptr(), nullptr);
    m.attr("Error") = error_type;
    m.attr("InputError") = input_error_type;
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const InputError& e) {
            PyErr_SetString(input_error_type.ptr(), e.what());
        } catch (const Error& e) {
            PyErr_SetString(error_type.ptr(), e.what());
        }
    });

    m.def("table_names", &list_tables, py::arg("path"),
          "names of the tables (HDF5 groups) in a brdftab file, in name order");
    m.def("file_attributes",
          [](const std::string& path) { return json_to_python(read_file_attributes(path)); },
          py::arg("path"), "file-level attributes (version, spec, creation time) as a dict");

    py::class_<Axis>(m, "Axis", "one table axis: node placement in user units")
        .def_readonly("name", &Axis::name)
        .def_readonly("unit", &Axis::unit)
        .def_readonly("min", &Axis::min)
        .def_readonly("max", &Axis::max)
        .def_readonly("count", &Axis::count)
        .def_property_readonly("spacing", [](const Axis& a) { return std::string(spacing_name(a.spacing)); })
        .def_property_readonly("values",
                               [](const Axis& a) {
                                   return py::array_t<double>(py::ssize_t(a.values.size()),
                                                              a.values.data());
                               })
        .def("warp", &Axis::warp, py::arg("t"), "x(t): node k sits at t = k/(count-1)")
        .def("unwarp", &Axis::unwarp, py::arg("x"), "t(x), the coordinate interpolation acts on")
        .def("__repr__", [](const Axis& a) {
            return "Axis('" + a.name + "', [" + std::to_string(a.min) + ", " +
                   std::to_string(a.max) + "] " + a.unit + ", " + std::to_string(a.count) +
                   " nodes, " + spacing_name(a.spacing) + ")";
        });

    py::class_<PyTable>(m, "_Table")
        .def(py::init<const std::string&, const std::string&>(), py::arg("path"), py::arg("name"))
        .def_readonly("path", &PyTable::path)
        .def_property_readonly("name", [](const PyTable& t) { return t.lookup->table().name; })
        .def_property_readonly("model", [](const PyTable& t) { return t.lookup->model(); })
        .def_property_readonly("quantity", [](const PyTable& t) { return t.lookup->quantity(); })
        .def_property_readonly("units", [](const PyTable& t) { return t.lookup->units(); })
        .def_property_readonly("description",
                               [](const PyTable& t) { return t.lookup->table().description; })
        .def_property_readonly("parameters",
                               [](const PyTable& t) { return json_to_python(t.lookup->parameters()); })
        .def_property_readonly("axes", [](const PyTable& t) { return t.lookup->axes(); })
        .def_property_readonly("coordinate_names",
                               [](const PyTable& t) { return t.lookup->coordinate_names(); })
        .def_property_readonly("has_recombination",
                               [](const PyTable& t) { return t.lookup->has_recombination(); })
        .def_property_readonly("has_stderr", [](const PyTable& t) { return bool(t.stderr_table); })
        .def_property_readonly(
            "values",
            [](py::object self) {
                const PyTable& t = self.cast<const PyTable&>();
                return view(t.lookup->table().value, t.lookup->axes(), self);
            })
        .def_property_readonly(
            "stderr",
            [](py::object self) -> py::object {
                const PyTable& t = self.cast<const PyTable&>();
                const TableData& d = t.lookup->table();
                if (d.stderr_.size() != d.value.size()) return py::none();
                return view(d.stderr_, d.axes, self);
            })
        .def_property_readonly("provenance",
                               [](const PyTable& t) {
                                   const TableData& d = t.lookup->table();
                                   py::dict p;
                                   p["method"] = method_attribute(d);
                                   p["samples_requested"] = d.samples_requested;
                                   p["tolerance_requested"] = d.tolerance_requested;
                                   p["abs_floor"] = d.abs_floor;
                                   p["tolerance_achieved"] = d.tolerance_achieved;
                                   p["seed"] = d.seed;
                                   p["precision"] = d.precision;
                                   p["device"] = d.device;
                                   p["version"] = d.version;
                                   p["elapsed_seconds"] = d.elapsed_seconds;
                                   p["total_samples"] = d.total_samples;
                                   return p;
                               })
        .def("_eval_rows",
             [](const PyTable& t, const py::array& points, const std::string& interp,
                const std::string& mode) { return t.eval_rows(points, interp, mode, false); })
        .def("_eval_stderr_rows",
             [](const PyTable& t, const py::array& points, const std::string& interp,
                const std::string& mode) { return t.eval_rows(points, interp, mode, true); })
        .def("_order",
             [](const PyTable& t, const std::vector<std::string>& names) {
                 // Which given name goes to each coordinate; unknown or missing
                 // names raise the library's message (as `brdftab query`).
                 std::map<std::string, double> probe;
                 for (std::size_t k = 0; k < names.size(); ++k) probe[names[k]] = double(k);
                 std::vector<std::size_t> order;
                 for (double k : t.lookup->ordered_coordinates(probe, "arguments"))
                     order.push_back(std::size_t(k));
                 return order;
             })
        .def("_clamped",
             [](const PyTable& t, const py::array& points) {
                 // Per axis whose coordinates the lookup clamps: (name, how
                 // many points, the first such value, min, max); phi_d is
                 // folded or wrapped first, as `brdftab query` warns.
                 const auto& axes = t.lookup->axes();
                 const DoubleArray rows = rows_of(points, t.lookup->coordinate_names().size(), "coordinates");
                 const std::size_t n = std::size_t(rows.shape(0)), width = std::size_t(rows.shape(1));
                 py::list out;
                 for (std::size_t a = 0; a < axes.size() && a < width; ++a) {
                     const double tol = 1e-9 * (axes[a].max - axes[a].min);
                     std::size_t count = 0;
                     double first = 0;
                     for (std::size_t i = 0; i < n; ++i) {
                         const double given = rows.data()[i * width + a];
                         const double x = lookup_internal::fold_periodic(axes[a], given);
                         if (x < axes[a].min - tol || x > axes[a].max + tol) {
                             if (count++ == 0) first = given;
                         }
                     }
                     if (count) out.append(py::make_tuple(axes[a].name, count, first, axes[a].min, axes[a].max));
                 }
                 return out;
             })
        .def_property_readonly("certificate",
                               [](const PyTable& t) -> py::object {
                                   const auto c = read_stored_certificate(t.path, t.lookup->table().name);
                                   if (!c) return py::none();
                                   py::dict d;
                                   d["max_error"] = c->max_error;
                                   d["rms_error"] = c->rms_error;
                                   d["measure"] = c->absolute ? "absolute" : "relative";
                                   d["abs_floor"] = c->abs_floor;
                                   d["interpolation"] = c->interpolation;
                                   d["target"] = c->target;
                                   d["passed"] = c->passed;
                                   return std::move(d);
                               })
        .def("_bind",
             [](const PyTable& t, const std::map<std::string, double>& params,
                const std::string& interp, const std::string& mode) {
                 return PyBound{std::make_shared<const BoundTable>(
                     t.lookup->bind(params, interpolation_of(interp), out_of_range_of(mode)))};
             });

    py::class_<PyBound>(m, "_Bound")
        .def_property_readonly("can_sample", [](const PyBound& b) { return b.bound->can_sample(); })
        .def_property_readonly("sampling_error",
                               [](const PyBound& b) { return b.bound->sampling_error(); })
        .def("_eval",
             [](const PyBound& b, const py::array& wi_in, const py::array& wo_in) {
                 const DoubleArray wi = rows_of(wi_in, 3, "wi"), wo = rows_of(wo_in, 3, "wo");
                 const py::ssize_t n = wi.shape(0);
                 py::array_t<double> out(n);
                 double* dst = out.mutable_data();
                 {
                     py::gil_scoped_release release;
                     for (py::ssize_t k = 0; k < n; ++k)
                         dst[k] = b.bound->eval(vec_at(wi, k), vec_at(wo, k));
                 }
                 return out;
             })
        .def("_pdf",
             [](const PyBound& b, const py::array& wi_in, const py::array& wo_in) {
                 const DoubleArray wi = rows_of(wi_in, 3, "wi"), wo = rows_of(wo_in, 3, "wo");
                 const py::ssize_t n = wi.shape(0);
                 py::array_t<double> out(n);
                 double* dst = out.mutable_data();
                 {
                     py::gil_scoped_release release;
                     for (py::ssize_t k = 0; k < n; ++k)
                         dst[k] = b.bound->pdf(vec_at(wi, k), vec_at(wo, k));
                 }
                 return out;
             })
        .def("_sample", [](const PyBound& b, const py::array& wi_in, const py::array& u_in) {
            const DoubleArray wi = rows_of(wi_in, 3, "wi"), u = rows_of(u_in, 2, "u");
            const py::ssize_t n = wi.shape(0);
            py::array_t<double> wo({n, py::ssize_t(3)});
            py::array_t<double> weight(n), pdf(n), value(n);
            double *pw = wo.mutable_data(), *pweight = weight.mutable_data(),
                   *ppdf = pdf.mutable_data(), *pvalue = value.mutable_data();
            {
                py::gil_scoped_release release;
                for (py::ssize_t k = 0; k < n; ++k) {
                    const double* uk = u.data(k, 0);
                    const SampleResult s = b.bound->sample(vec_at(wi, k), uk[0], uk[1]);
                    pw[3 * k] = s.wo.x;
                    pw[3 * k + 1] = s.wo.y;
                    pw[3 * k + 2] = s.wo.z;
                    pweight[k] = s.weight;
                    ppdf[k] = s.pdf;
                    pvalue[k] = s.value;
                }
            }
            return py::make_tuple(wo, weight, pdf, value);
        });
}
