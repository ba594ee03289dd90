// lookup_internal.h — helpers shared by the files of the lookup library
// (lookup.cpp, interpolate.cpp, recombine.cpp, directions.cpp, sample.cpp).
// Not installed: the public API is lookup.h alone.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "host/core/grid.h"
#include "host/core/table.h"
#include "host/lookup/lookup.h"

namespace brdftab::lookup_internal {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

// Numbers in messages (10 significant digits) and "[min, max] unit"
// (interpolate.cpp).
std::string fmt_num(double v);
std::string range_text(const Axis& a);

// A phi_d coordinate outside its axis, reduced as direction lookups reduce
// it (directions.cpp): folded to |phi_d| in [0, 180] deg when the axis lies
// within [0, 180] (isotropy), else wrapped into [min, min + 360).  Other
// axes, units other than deg/rad, and values inside the axis are returned
// unchanged.
double fold_periodic(const Axis& a, double x);

// Validate a coordinate against its axis and apply the out-of-range policy
// (interpolate.cpp); phi_d is first reduced by fold_periodic().
double resolve(const Axis& a, double x, OutOfRange mode, const std::string& table);

// Sparse 1-D interpolation weights over real node indices of one axis.
struct AxisWeights {
    std::size_t idx[4];
    double w[4];
    int n = 0;
    void add(std::size_t i, double wt) {
        for (int k = 0; k < n; ++k)
            if (idx[k] == i) {
                w[k] += wt;
                return;
            }
        idx[n] = i;
        w[n] = wt;
        ++n;
    }
    void single(std::size_t i) {
        n = 0;
        add(i, 1.0);
    }
};

// Weights of a range-resolved coordinate on one axis, and their
// tensor-product contraction with a row-major array (interpolate.cpp).
void axis_weights(const Axis& a, double x, Interpolation interp, AxisWeights& out);
// The same from the axis' normalised coordinate t (node k at k/(count-1)).
void axis_weights_t(const Axis& a, double t, Interpolation interp, AxisWeights& out);
double contract(const AxisWeights* ws, const std::size_t* strides, std::size_t dims,
                const double* values, std::size_t d = 0, std::size_t offset = 0);

// Table names a "recombine" object refers to, after checking its shape
// (recombine.cpp).
std::vector<std::string> recombine_tables(const TableData& head);

// Angular coordinates of (wi, wo) in axis units, phi reduced to the phi
// axis' span (directions.cpp).
void direction_coords(const LookupTable::AngleLayout& L, const Axis* phi_axis,
                      const Vec3& wi_in, const Vec3& wo_in, double& xi, double& xo,
                      double& xphi, double& phi_i);

}  // namespace brdftab::lookup_internal
