/*
 * compat.h — the one set of macros that lets every shared math header compile
 * both as OpenCL C 1.2 (device) and as C++17 (host serial reference path and
 * unit tests).  Include it first from every shared header.
 *
 * Conventions used by all shared code:
 *   REAL        the kernel floating type: double by default, float when the
 *               program is built with -D BT_REAL_IS_FLOAT=1 (`--precision float`).
 *               The host C++ build always uses double.
 *   ACCUM       accumulator type for per-batch sums: double whenever the device
 *               has cl_khr_fp64 (BT_HAS_FP64=1), else float.
 *   R(x)        a REAL literal: R(0.5).  Bare `0.5` would be a double in OpenCL C
 *               and needs fp64 even in float mode.
 *   BT_INLINE   function qualifier for shared functions (static inline).
 *   uint, ulong the OpenCL fixed-width unsigned types (32 and 64 bit).
 *   Math calls (sqrt, erf, erfc, expm1, fabs, fmin, fmax, floor, copysign)
 *   are written bare: OpenCL provides them as overloaded built-ins, and the
 *   C++ branch below brings the std:: overloads into scope.  sin, cos, tan,
 *   exp, log, log1p, atan, atan2, asin and acos are called as bt_sin, ...
 *   (bt_math.h): PoCL's double built-ins of these are not vectorised.
 *   BT_TABLE    qualifier of a program-scope constant table.
 *   Shared code never calls pow(): measured, PoCL's double pow is about ten
 *   times slower than glibc's, so integer powers are written as products
 *   (docs/contributing.md collects such platform notes).
 */
#ifndef BRDFTAB_COMPAT_H
#define BRDFTAB_COMPAT_H

#if defined(__OPENCL_C_VERSION__) || defined(__OPENCL_VERSION__)
/* ------------------------------------------------------------ OpenCL C */
#define BT_DEVICE 1
#if defined(BT_HAS_FP64) && BT_HAS_FP64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif
#if defined(BT_REAL_IS_FLOAT) && BT_REAL_IS_FLOAT
typedef float REAL;
#else
typedef double REAL;
#endif
#if defined(BT_HAS_FP64) && BT_HAS_FP64
typedef double ACCUM;
#else
typedef float ACCUM;
#endif
#define BT_INLINE static inline
#define BT_GLOBAL __global
#define BT_CONSTANT __constant
#define BT_TABLE __constant
/* BT_SLP_SPLIT(x) is x, bit for bit (x + -0.0 == x for every x, -0 and NaN
 * included), written so that PoCL's compiler cannot prove it.  Why: PoCL
 * optimises the program twice (when it is built, and again when it makes the
 * work-group function), and both rounds run clang's SLP vectoriser before
 * LLVM's loop vectoriser sees the work-item loop.  SLP packs two alike scalar
 * chains (x and y of a vector, the i and o directions, two divisions whose
 * results meet) into <2 x double>, and the loop vectoriser then refuses the
 * whole work-item loop ("instruction return type cannot be vectorized").
 * A pair whose members differ by one operation is no longer isomorphic, so
 * shared code wraps one member of each pair that PoCL packed.
 * The added term must stay opaque through both rounds: a constant, or a
 * condition on get_local_size / get_local_id (which PoCL fixes for the
 * work-group function), folds away before the second round's SLP runs and
 * the pair is packed again (measured); the number of work groups is known
 * only at run time.  Cost: one add of a loop-invariant value.  Found and
 * checked with `scripts/slp-pairs.sh --pocl` (docs/contributing.md). */
#define BT_SLP_SPLIT(x) ((x) + (get_num_groups(0) == 0 ? R(1.0) : R(-0.0)))

#else
/* ------------------------------------------------------------------ C++ */
#define BT_DEVICE 0
#include <cmath>
#include <cstdint>
typedef double REAL;
typedef double ACCUM;
typedef std::uint32_t uint;
typedef std::uint64_t ulong;
#define BT_INLINE static inline
#define BT_GLOBAL
#define BT_CONSTANT
/* static: the header can be included from several translation units. */
#define BT_TABLE static const
#define BT_SLP_SPLIT(x) (x) /* a device-only concern (see above) */
using std::acos;
using std::atan;
using std::atan2;
using std::copysign;
using std::cos;
using std::erf;
using std::exp;
using std::fabs;
using std::floor;
using std::fmax;
using std::fmin;
using std::log;
using std::sin;
using std::sqrt;
using std::tan;
#endif

#define R(x) ((REAL)(x))

/* Constants as REAL.  Written with enough digits for double. */
#define BT_PI R(3.14159265358979323846)
#define BT_TWO_PI R(6.28318530717958647692)
#define BT_INV_PI R(0.31830988618379067154)
#define BT_HALF_PI R(1.57079632679489661923)
#define BT_SQRT_PI R(1.77245385090551602730)

BT_INLINE REAL bt_sqr(REAL x) { return x * x; }
BT_INLINE REAL bt_clamp(REAL x, REAL lo, REAL hi) { return fmin(fmax(x, lo), hi); }
/* sqrt that tolerates tiny negative arguments produced by rounding. */
BT_INLINE REAL bt_safe_sqrt(REAL x) { return sqrt(fmax(x, R(0.0))); }
/* bt_safe_acos (acos of a clamped argument) lives in bt_math.h, next to the
 * inlinable acos it calls. */

#endif /* BRDFTAB_COMPAT_H */
