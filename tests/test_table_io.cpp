// test_table_io.cpp — HDF5 table files: round trips, metadata, dimension
// scales, error paths and the no-damage guarantee of a failed write.
//
// Oracles: the written doubles themselves (float64), an independent (float)
// cast (float32), a hand-written IEEE binary16 rounding (float16, checked on
// hand values against exact neighbours), the HDF5 C API read directly (layout)
// and h5py through scripts/read_table.py (a reader that shares no code).
#include <doctest/doctest.h>

#include "test_support.h"

#include <hdf5.h>
#include <hdf5_hl.h>

#include <Imath/half.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <sys/stat.h>
#include <unistd.h>

#include "host/core/error.h"
#include "host/io/table_io.h"

namespace fs = std::filesystem;
using namespace brdftab;

namespace {

fs::path scratch_dir(const std::string& sub) { return test::scratch_dir(BT_BINARY_DIR, "test_table_io", sub); }
using test::axis;
using test::kPi;

// A smooth analytic 3-D table with stderr and samples.
TableData smooth_table(std::size_t n0, std::size_t n1, std::size_t n2, StoredType st) {
    TableData t;
    t.name = "brdf";
    t.model = "rough-dielectric";
    t.quantity = "brdf";
    t.units = "1/sr";
    t.description = "test table \u00b5 \u03b8";  // non-ASCII: UTF-8 must survive
    t.parameters = {{"eta", 1.5}, {"alpha", 0.25}, {"distribution", "ggx"},
                    {"nested", {{"list", {1, 2, 3}}}}};
    t.axes.push_back(axis("alpha", "1", 0.05, 1.0, n0));
    Axis th = axis("theta_i", "deg", 0.0, 89.0, n1);
    th.spacing = Spacing::Cos;  // values need not follow the spacing for storage
    t.axes.push_back(th);
    t.axes.push_back(axis("phi_d", "deg", 0.0, 180.0, n2));
    const std::size_t n = n0 * n1 * n2;
    t.value.resize(n);
    t.stderr_.resize(n);
    t.samples.resize(n);
    for (std::size_t i = 0; i < n0; ++i)
        for (std::size_t j = 0; j < n1; ++j)
            for (std::size_t k = 0; k < n2; ++k) {
                const std::size_t c = (i * n1 + j) * n2 + k;
                const double a = t.axes[0].values[i], th_ = t.axes[1].values[j] * kPi / 180,
                             ph = t.axes[2].values[k] * kPi / 180;
                t.value[c] = std::exp(-a) * std::cos(th_) * (1.2 + std::cos(ph)) / 3.0;
                t.stderr_[c] = 1e-3 * t.value[c] + 1e-7;
                t.samples[c] = static_cast<std::uint32_t>(1000 + c);
            }
    t.method = Method::Rqmc;
    t.samples_requested = 1ull << 40;  // beyond 32 bits on purpose
    t.tolerance_requested = 1e-3;
    t.abs_floor = 1e-6;
    t.tolerance_achieved = 7.5e-4;
    t.seed = 0xfedcba9876543210ull;
    t.precision = "double";
    t.device = "pthread-cpu";
    t.version = "9.8.7-test";
    t.spec_file = "specs/example.toml";
    t.elapsed_seconds = 12.25;
    t.total_samples = 123456789012ull;
    t.stored_type = st;
    t.compression = 6;
    t.keep_stderr = true;
    return t;
}

// Correctly rounded binary16 value of d (nearest, ties to even), written from
// the IEEE 754 definition: 11 significant bits, exponent >= -14 (below that a
// fixed spacing of 2^-24), overflow to infinity from 65520 = 65504 + ulp/2.
double ref_half(double d) {
    if (std::isnan(d) || std::isinf(d)) return d;
    if (d == 0) return d;
    const double ad = std::fabs(d);
    int e = static_cast<int>(std::floor(std::log2(ad)));
    // log2 may be off by one right at powers of two: fix by direct comparison.
    if (std::ldexp(1.0, e) > ad) --e;
    if (std::ldexp(1.0, e + 1) <= ad) ++e;
    const double ulp = std::ldexp(1.0, std::max(e, -14) - 10);
    const double q = std::nearbyint(ad / ulp) * ulp;  // exact scaling; nearbyint ties to even
    const double r = q >= 65520.0 ? INFINITY : q;      // 65520 itself rounds to even (= inf)
    return std::copysign(r, d);
}

std::string slurp(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(f), {});
}

std::vector<std::string> dir_entries(const fs::path& d) {
    std::vector<std::string> out;
    for (const auto& e : fs::directory_iterator(d)) out.push_back(e.path().filename().string());
    std::sort(out.begin(), out.end());
    return out;
}

template <class F>
std::string error_message(F&& f) {
    try {
        f();
    } catch (const std::exception& e) {
        return e.what();
    }
    return "";
}

void check_metadata_equal(const TableData& a, const TableData& b) {
    CHECK(a.name == b.name);
    CHECK(a.model == b.model);
    CHECK(a.quantity == b.quantity);
    CHECK(a.units == b.units);
    CHECK(a.description == b.description);
    CHECK(a.parameters == b.parameters);
    CHECK(a.kind == b.kind);
    CHECK(a.method == b.method);
    CHECK(a.samples_requested == b.samples_requested);
    CHECK(a.tolerance_requested == b.tolerance_requested);
    CHECK(a.abs_floor == b.abs_floor);
    CHECK(a.tolerance_achieved == b.tolerance_achieved);
    CHECK(a.seed == b.seed);
    CHECK(a.precision == b.precision);
    CHECK(a.device == b.device);
    CHECK(a.version == b.version);
    CHECK(a.spec_file == b.spec_file);
    CHECK(a.elapsed_seconds == b.elapsed_seconds);
    CHECK(a.total_samples == b.total_samples);
    CHECK(a.stored_type == b.stored_type);
    CHECK(a.compression == b.compression);
    REQUIRE(a.axes.size() == b.axes.size());
    for (std::size_t i = 0; i < a.axes.size(); ++i) {
        CHECK(a.axes[i].name == b.axes[i].name);
        CHECK(a.axes[i].unit == b.axes[i].unit);
        CHECK(a.axes[i].min == b.axes[i].min);
        CHECK(a.axes[i].max == b.axes[i].max);
        CHECK(a.axes[i].count == b.axes[i].count);
        CHECK(a.axes[i].spacing == b.axes[i].spacing);
        CHECK(a.axes[i].values == b.axes[i].values);  // axes are always float64: exact
    }
    CHECK(a.samples == b.samples);
}

}  // namespace

TEST_CASE("stored type names and table indexing") {
    for (StoredType t : {StoredType::Float64, StoredType::Float32, StoredType::Float16})
        CHECK(parse_stored_type(stored_type_name(t)) == t);
    CHECK(std::string(stored_type_name(StoredType::Float16)) == "float16");
    CHECK_THROWS_AS(parse_stored_type("float128"), InputError);

    TableData t = smooth_table(2, 3, 4, StoredType::Float64);
    CHECK(t.cell_count() == 24);
    CHECK(t.shape() == std::vector<std::size_t>{2, 3, 4});
    // Row-major, last axis fastest: (i, j, k) -> (i*3 + j)*4 + k.
    CHECK(t.flat_index({0, 0, 0}) == 0);
    CHECK(t.flat_index({0, 0, 3}) == 3);
    CHECK(t.flat_index({0, 1, 0}) == 4);
    CHECK(t.flat_index({1, 2, 3}) == 23);
    CHECK_THROWS_AS(t.flat_index({2, 0, 0}), Error);
    CHECK_THROWS_AS(t.flat_index({0, 0}), Error);
}

TEST_CASE("float64 round trip is exact, with all metadata") {
    fs::path d = scratch_dir("f64");
    TableData t = smooth_table(3, 5, 7, StoredType::Float64);
    TableData t2 = smooth_table(2, 2, 2, StoredType::Float32);
    t2.name = "albedo";
    t2.keep_stderr = false;
    write_tables((d / "t.h5").string(), {t, t2});

    CHECK(list_tables((d / "t.h5").string()) == std::vector<std::string>{"albedo", "brdf"});
    TableData r = read_table((d / "t.h5").string(), "brdf");
    check_metadata_equal(t, r);
    CHECK(r.value == t.value);
    CHECK(r.stderr_ == t.stderr_);
    CHECK(r.keep_stderr);

    nlohmann::json fa = read_file_attributes((d / "t.h5").string());
    CHECK(fa.at("brdftab_format") == 1);
    CHECK(fa.at("brdftab_version") == BRDFTAB_VERSION);
    const std::string created = fa.at("created");
    CHECK(std::regex_match(created, std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ)")));
    std::tm tm{};
    strptime(created.c_str(), "%Y-%m-%dT%H:%M:%SZ", &tm);
    CHECK(std::fabs(std::difftime(timegm(&tm), std::time(nullptr))) < 120);  // UTC, not local
    CHECK(dir_entries(d) == std::vector<std::string>{"t.h5"});  // no temp file left
}

TEST_CASE("a table without axes is a scalar dataset") {
    fs::path d = scratch_dir("scalar");
    TableData t;
    t.name = "hemispherical_albedo";
    t.value = {0.8125};
    t.stored_type = StoredType::Float64;
    write_tables((d / "s.h5").string(), {t});
    TableData r = read_table((d / "s.h5").string(), t.name);
    CHECK(r.axes.empty());
    CHECK(r.value == std::vector<double>{0.8125});
    CHECK(r.stderr_.empty());
}

TEST_CASE("float32 storage equals an independent float cast") {
    fs::path d = scratch_dir("f32");
    TableData t = smooth_table(4, 5, 6, StoredType::Float32);
    // Add values over many binades, including ones that do not fit a float.
    std::mt19937_64 rng(12345);
    std::uniform_real_distribution<double> u(-40, 40);
    for (std::size_t c = 0; c < t.value.size(); ++c)
        t.value[c] = (c % 2 ? -1 : 1) * std::exp(u(rng)) * (1 + 1e-12 * double(c));
    t.value[0] = 1e300;   // float overflow -> inf
    t.value[1] = 1e-50;   // float underflow -> 0
    write_tables((d / "t.h5").string(), {t});
    TableData r = read_table((d / "t.h5").string(), "brdf");
    CHECK(r.stored_type == StoredType::Float32);
    std::size_t bad = 0;
    for (std::size_t c = 0; c < t.value.size(); ++c) {
        volatile float f = static_cast<float>(t.value[c]);  // the oracle: C++ nearest cast
        if (r.value[c] != static_cast<double>(f)) ++bad;
        if (std::isfinite(f) && f != 0.0f)  // float rounding bound 2^-24 relative
            CHECK(std::fabs(r.value[c] - t.value[c]) <= std::ldexp(std::fabs(t.value[c]), -24));
    }
    CHECK(bad == 0);
    CHECK(std::isinf(r.value[0]));
    CHECK(r.value[1] == 0.0);
    for (std::size_t c = 0; c < t.stderr_.size(); ++c)
        CHECK(r.stderr_[c] == static_cast<double>(static_cast<float>(t.stderr_[c])));
}

TEST_CASE("float16 storage is correctly rounded binary16") {
    // The hand-written oracle, checked on values whose neighbours are known
    // exactly: halves near 1/3 are k/4096 (exponent -2, 10 mantissa bits).
    CHECK(ref_half(1.0) == 1.0);
    CHECK(ref_half(0.5) == 0.5);
    CHECK(ref_half(65504.0) == 65504.0);
    CHECK(ref_half(1.0 / 3.0) == 1365.0 / 4096.0);  // 1365.33 -> 1365
    CHECK(ref_half(2.0 / 3.0) == 1365.0 / 2048.0);  // 1365.33 -> 1365 (exponent -1)
    CHECK(ref_half(65519.0) == 65504.0);
    CHECK(std::isinf(ref_half(65520.0)));
    CHECK(ref_half(1.0 + std::ldexp(1.0, -11)) == 1.0);  // tie -> even
    CHECK(ref_half(1.0 + 3 * std::ldexp(1.0, -11)) == 1.0 + std::ldexp(1.0, -9));  // tie -> even
    CHECK(ref_half(std::ldexp(0.75, -24)) == std::ldexp(1.0, -24));  // subnormal
    CHECK(ref_half(std::ldexp(0.5, -24)) == 0.0);                    // tie -> even (0)

    fs::path d = scratch_dir("f16");
    TableData t = smooth_table(3, 6, 9, StoredType::Float16);
    std::mt19937_64 rng(777);
    std::uniform_real_distribution<double> u(-20, 11);
    for (std::size_t c = 0; c < t.value.size(); ++c) t.value[c] = std::exp(u(rng));
    const std::vector<double> hand = {
        1.0, 0.5, 65504.0, 1.0 / 3.0, 2.0 / 3.0, 0.1, 65519.0, 70000.0, -2.5, 0.0,
        std::ldexp(0.75, -24), std::ldexp(1.0, -14) * 1.0009765625,
        // Double-rounding trap: just above the midpoint between 1 and 1+2^-10.
        // (float) of it is exactly the midpoint, which then rounds to even (1).
        1.0 + std::ldexp(1.0, -11) + std::ldexp(1.0, -40),
        1.0 - std::ldexp(1.0, -12) - std::ldexp(1.0, -41)};
    std::copy(hand.begin(), hand.end(), t.value.begin());
    write_tables((d / "t.h5").string(), {t});
    TableData r = read_table((d / "t.h5").string(), "brdf");
    CHECK(r.stored_type == StoredType::Float16);
    CHECK(r.value[0] == 1.0);
    CHECK(r.value[1] == 0.5);
    CHECK(r.value[2] == 65504.0);
    CHECK(r.value[3] == 1365.0 / 4096.0);
    CHECK(r.value[6] == 65504.0);
    CHECK(std::isinf(r.value[7]));
    CHECK(r.value[12] == 1.0 + std::ldexp(1.0, -10));  // not the double-rounded 1.0
    CHECK(Imath::half(static_cast<float>(hand[12])) == Imath::half(1.0f));  // the trap is real
    std::size_t bad_ref = 0, bad_imath = 0;
    for (std::size_t c = 0; c < t.value.size(); ++c) {
        if (r.value[c] != ref_half(t.value[c])) ++bad_ref;
        if (c >= hand.size() &&
            r.value[c] != static_cast<double>(static_cast<float>(
                              Imath::half(static_cast<float>(t.value[c])))))
            ++bad_imath;
        if (std::isfinite(r.value[c]) && std::fabs(t.value[c]) >= std::ldexp(1.0, -14))
            CHECK(std::fabs(r.value[c] - t.value[c]) <= std::ldexp(std::fabs(t.value[c]), -11));
    }
    CHECK(bad_ref == 0);
    CHECK(bad_imath == 0);
}

TEST_CASE("stderr is omitted when keep_stderr is false") {
    fs::path d = scratch_dir("nostderr");
    TableData t = smooth_table(2, 3, 4, StoredType::Float32);
    t.keep_stderr = false;
    t.samples.clear();
    write_tables((d / "t.h5").string(), {t});
    TableData r = read_table((d / "t.h5").string(), "brdf");
    CHECK_FALSE(r.keep_stderr);
    CHECK(r.stderr_.empty());
    CHECK(r.samples.empty());

    hid_t f = H5Fopen((d / "t.h5").string().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    REQUIRE(f >= 0);
    CHECK(H5Lexists(f, "brdf/value", H5P_DEFAULT) > 0);
    CHECK(H5Lexists(f, "brdf/stderr", H5P_DEFAULT) == 0);
    CHECK(H5Lexists(f, "brdf/samples", H5P_DEFAULT) == 0);
    H5Fclose(f);
}

TEST_CASE("layout seen through the HDF5 C API: dimension scales, types, chunks") {
    fs::path d = scratch_dir("layout");
    TableData t = smooth_table(6, 300, 300, StoredType::Float64);  // 720 kB per (j,k) slab
    write_tables((d / "t.h5").string(), {t});

    hid_t f = H5Fopen((d / "t.h5").string().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    REQUIRE(f >= 0);
    hid_t g = H5Gopen2(f, "brdf", H5P_DEFAULT);
    REQUIRE(g >= 0);
    for (const char* dsname : {"value", "stderr", "samples"}) {
        CAPTURE(dsname);
        hid_t ds = H5Dopen2(g, dsname, H5P_DEFAULT);
        REQUIRE(ds >= 0);
        for (unsigned i = 0; i < 3; ++i) {
            hid_t ax = H5Dopen2(g, t.axes[i].name.c_str(), H5P_DEFAULT);
            REQUIRE(ax >= 0);
            CHECK(H5DSis_scale(ax) > 0);
            CHECK(H5DSis_attached(ds, ax, i) > 0);
            CHECK(H5DSget_num_scales(ds, i) == 1);
            char label[64] = {0};
            H5DSget_label(ds, i, label, sizeof label);
            CHECK(std::string(label) == t.axes[i].name);
            H5Dclose(ax);
        }
        // Chunks: at most 1 MiB, the last two axes whole here (they fit).
        hid_t dcpl = H5Dget_create_plist(ds);
        hsize_t chunk[3] = {0, 0, 0};
        REQUIRE(H5Pget_chunk(dcpl, 3, chunk) == 3);
        hid_t ty = H5Dget_type(ds);
        const std::size_t bytes = chunk[0] * chunk[1] * chunk[2] * H5Tget_size(ty);
        CHECK(bytes <= (1u << 20));
        CHECK(chunk[1] == 300);
        CHECK(chunk[2] == 300);
        // shuffle + deflate, then the Fletcher-32 checksum of the stored bytes.
        REQUIRE(H5Pget_nfilters(dcpl) == 3);
        unsigned flags = 0;
        CHECK(H5Pget_filter2(dcpl, 0, &flags, nullptr, nullptr, 0, nullptr, nullptr) ==
              H5Z_FILTER_SHUFFLE);
        CHECK(H5Pget_filter2(dcpl, 1, &flags, nullptr, nullptr, 0, nullptr, nullptr) ==
              H5Z_FILTER_DEFLATE);
        CHECK(H5Pget_filter2(dcpl, 2, &flags, nullptr, nullptr, 0, nullptr, nullptr) ==
              H5Z_FILTER_FLETCHER32);
        H5Tclose(ty);
        H5Pclose(dcpl);
        H5Dclose(ds);
    }
    // Axis attributes.
    hid_t ax = H5Dopen2(g, "theta_i", H5P_DEFAULT);
    CHECK(H5Aexists(ax, "unit") > 0);
    CHECK(H5Aexists(ax, "spacing") > 0);
    CHECK(H5Aexists(ax, "min") > 0);
    CHECK(H5Aexists(ax, "max") > 0);
    {  // the node list is checksummed too (chunked, not compressed)
        hid_t dcpl = H5Dget_create_plist(ax);
        REQUIRE(H5Pget_nfilters(dcpl) == 1);
        unsigned flags = 0;
        CHECK(H5Pget_filter2(dcpl, 0, &flags, nullptr, nullptr, 0, nullptr, nullptr) ==
              H5Z_FILTER_FLETCHER32);
        H5Pclose(dcpl);
    }
    hid_t a = H5Aopen(ax, "spacing", H5P_DEFAULT);
    hid_t at = H5Aget_type(a);
    CHECK(H5Tis_variable_str(at) > 0);     // variable-length ...
    CHECK(H5Tget_cset(at) == H5T_CSET_UTF8);  // ... UTF-8, so h5py gives str
    H5Tclose(at);
    H5Aclose(a);
    H5Dclose(ax);
    // float16 type layout as h5py expects it.
    H5Gclose(g);
    H5Fclose(f);

    TableData h = smooth_table(2, 3, 4, StoredType::Float16);
    write_tables((d / "h.h5").string(), {h});
    f = H5Fopen((d / "h.h5").string().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    hid_t ds = H5Dopen2(f, "brdf/value", H5P_DEFAULT);
    hid_t ty = H5Dget_type(ds);
    std::size_t spos, epos, esize, mpos, msize;
    H5Tget_fields(ty, &spos, &epos, &esize, &mpos, &msize);
    CHECK(H5Tget_class(ty) == H5T_FLOAT);
    CHECK(H5Tget_size(ty) == 2);
    CHECK(spos == 15);
    CHECK(epos == 10);
    CHECK(esize == 5);
    CHECK(mpos == 0);
    CHECK(msize == 10);
    CHECK(H5Tget_ebias(ty) == 15);
    H5Tclose(ty);
    H5Dclose(ds);
    H5Fclose(f);
}

TEST_CASE("read errors are InputErrors naming the file and the choices") {
    fs::path d = scratch_dir("errors");
    const std::string p = (d / "t.h5").string();
    TableData a = smooth_table(2, 2, 2, StoredType::Float32);
    TableData b = a;
    b.name = "albedo";
    write_tables(p, {a, b});

    CHECK_THROWS_AS(read_table(p, "bdrf"), InputError);
    std::string msg = error_message([&] { read_table(p, "bdrf"); });
    CHECK(msg.find(p) != std::string::npos);
    CHECK(msg.find("bdrf") != std::string::npos);
    CHECK(msg.find("albedo") != std::string::npos);
    CHECK(msg.find("brdf") != std::string::npos);
    CHECK_THROWS_AS(read_table(p, "brdf/value"), InputError);  // a dataset, not a table

    const std::string missing = (d / "missing.h5").string();
    CHECK_THROWS_AS(read_table(missing, "brdf"), InputError);
    CHECK(error_message([&] { list_tables(missing); }).find(missing) != std::string::npos);

    const std::string text = (d / "text.h5").string();
    std::ofstream(text) << "not hdf5\n";
    CHECK_THROWS_AS(read_table(text, "brdf"), InputError);
    CHECK(error_message([&] { list_tables(text); }).find(text) != std::string::npos);

    // A valid HDF5 file that is not ours.
    const std::string other = (d / "other.h5").string();
    hid_t f = H5Fcreate(other.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    REQUIRE(f >= 0);
    hid_t g = H5Gcreate2(f, "brdf", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    H5Gclose(g);
    H5Fclose(f);
    CHECK_THROWS_AS(read_table(other, "brdf"), InputError);
    CHECK(error_message([&] { list_tables(other); }).find("brdftab") != std::string::npos);
    CHECK_THROWS_AS(read_file_attributes(other), InputError);
}

TEST_CASE("a failed write leaves an existing file untouched and no temp file") {
    fs::path d = scratch_dir("failed");
    const std::string p = (d / "t.h5").string();
    TableData good = smooth_table(3, 4, 5, StoredType::Float32);
    write_tables(p, {good});
    const std::string before = slurp(p);
    REQUIRE(!before.empty());

    SUBCASE("second table has a wrong value size (fails after the first is written)") {
        TableData bad = good;
        bad.name = "broken";
        bad.value.pop_back();
        TableData other = good;
        other.name = "another";
        CHECK_THROWS_AS(write_tables(p, {other, bad}), Error);
        std::string msg = error_message([&] { write_tables(p, {other, bad}); });
        CHECK(msg.find("broken") != std::string::npos);
    }
    SUBCASE("duplicate table names") {
        CHECK_THROWS_AS(write_tables(p, {good, good}), Error);
    }
    SUBCASE("mismatched stderr size") {
        TableData bad = good;
        bad.stderr_.resize(3);
        CHECK_THROWS_AS(write_tables(p, {bad}), Error);
    }
    SUBCASE("axis name clashing with a dataset name") {
        TableData bad = good;
        bad.axes[1].name = "value";
        CHECK_THROWS_AS(write_tables(p, {bad}), InputError);
    }
    SUBCASE("directory not writable") {
        if (::geteuid() == 0) {
            MESSAGE("running as root: permission bits do not stop writes, case skipped");
        } else {
            fs::permissions(d, fs::perms::owner_read | fs::perms::owner_exec);
            CHECK_THROWS_AS(write_tables(p, {good}), Error);
            fs::permissions(d, fs::perms::owner_all);
        }
    }
    CHECK(slurp(p) == before);
    CHECK(dir_entries(d) == std::vector<std::string>{"t.h5"});

    // A directory that does not exist: Error naming the HDF5 call, nothing created.
    const std::string nowhere = (d / "no-such-dir" / "t.h5").string();
    std::string msg = error_message([&] { write_tables(nowhere, {good}); });
    CHECK(msg.find("H5Fcreate") != std::string::npos);
    CHECK_FALSE(fs::exists(d / "no-such-dir"));
}

TEST_CASE("compression shrinks a smooth table") {
    fs::path d = scratch_dir("compress");
    TableData t = smooth_table(16, 64, 64, StoredType::Float32);
    t.stderr_.clear();
    t.samples.clear();
    TableData raw = t;
    raw.compression = 0;
    write_tables((d / "c.h5").string(), {t});
    write_tables((d / "u.h5").string(), {raw});
    const auto cs = fs::file_size(d / "c.h5"), us = fs::file_size(d / "u.h5");
    MESSAGE("smooth 16x64x64 float32: uncompressed " << us << " B, deflate-6 " << cs << " B");
    CHECK(us >= 16 * 64 * 64 * 4);  // the data is really in there
    CHECK(cs * 4 < us * 3);  // measured ~0.66 with deflate 6 + shuffle
    CHECK(read_table((d / "c.h5").string(), "brdf").value ==
          read_table((d / "u.h5").string(), "brdf").value);
    CHECK(read_table((d / "c.h5").string(), "brdf").compression == 6);
    CHECK(read_table((d / "u.h5").string(), "brdf").compression == 0);
}

TEST_CASE("h5py reads the file (scripts/read_table.py)") {
    if (!fs::exists("/usr/bin/python3") ||
        std::system("/usr/bin/python3 -c 'import h5py' >/dev/null 2>&1") != 0) {
        MESSAGE("/usr/bin/python3 with h5py not available: skipped");
        return;
    }
    fs::path d = scratch_dir("h5py");
    TableData t = smooth_table(3, 4, 5, StoredType::Float16);
    TableData t2 = smooth_table(2, 3, 2, StoredType::Float64);
    t2.name = "albedo";
    write_tables((d / "t.h5").string(), {t, t2});
    const std::string cmd = "/usr/bin/python3 " + std::string(BT_SOURCE_DIR) +
                            "/scripts/read_table.py " + (d / "t.h5").string() + " brdf 2>&1";
    FILE* pipe = ::popen(cmd.c_str(), "r");
    REQUIRE(pipe);
    std::string out;
    char buf[512];
    while (std::fgets(buf, sizeof buf, pipe)) out += buf;
    const int rc = ::pclose(pipe);
    INFO(out);
    REQUIRE(rc == 0);
    auto has = [&](const std::string& s) { return out.find(s) != std::string::npos; };
    CHECK(has("brdftab_format: 1"));
    CHECK(has("tables: albedo, brdf"));
    CHECK(has("value: shape (3, 4, 5) dtype float16"));
    CHECK(has("stderr: shape (3, 4, 5) dtype float16"));
    CHECK(has("samples: shape (3, 4, 5) dtype uint32"));
    CHECK(has("axis alpha: 3 nodes 0.05 .. 1 unit 1 spacing linear"));
    CHECK(has("axis theta_i: 4 nodes 0 .. 89 unit deg spacing cos"));
    CHECK(has("axis phi_d: 5 nodes 0 .. 180 unit deg spacing linear"));
    CHECK(has("dims: alpha, theta_i, phi_d"));
    CHECK(has("model: rough-dielectric"));
    CHECK(has("seed: 18364758544493064720"));
    CHECK(has("parameters.eta: 1.5"));
    CHECK(has("description: test table \u00b5 \u03b8"));
    // value[0,0,0] = exp(-0.05) * cos(0) * 2.2 / 3 rounded to half and printed by numpy.
    const double v000 = ref_half(std::exp(-0.05) * 2.2 / 3.0);
    std::ostringstream want;
    want.precision(17);
    want << "value[0,0,0]: " << v000;
    CHECK(has(want.str()));
}

// ------------------------------------------------- hostile and damaged files
// Files edited through the HDF5 C API the way a foreign tool (or an attacker)
// could: every case must be an InputError naming the file and the object,
// never a crash, an overrun or a silently different table.

namespace {

// Replace attribute `name` of object `obj_path` in `file` by a 1-D array of
// `n` elements of `type`, every element `v` (converted by HDF5).
void set_array_attr(const std::string& file, const char* obj_path, const char* name, hid_t type,
                    hsize_t n, double v) {
    hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    REQUIRE(f >= 0);
    hid_t o = H5Oopen(f, obj_path, H5P_DEFAULT);
    REQUIRE(o >= 0);
    if (H5Aexists(o, name) > 0) REQUIRE(H5Adelete(o, name) >= 0);
    hid_t sp = H5Screate_simple(1, &n, nullptr);
    hid_t at = H5Acreate2(o, name, type, sp, H5P_DEFAULT, H5P_DEFAULT);
    REQUIRE(at >= 0);
    std::vector<double> data(n, v);
    REQUIRE(H5Awrite(at, H5T_NATIVE_DOUBLE, data.data()) >= 0);
    H5Aclose(at);
    H5Sclose(sp);
    H5Oclose(o);
    H5Fclose(f);
}

// Scalar variant (n = 0 means H5S_SCALAR).
void set_scalar_attr(const std::string& file, const char* obj_path, const char* name, hid_t type,
                     double v) {
    hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    REQUIRE(f >= 0);
    hid_t o = H5Oopen(f, obj_path, H5P_DEFAULT);
    REQUIRE(o >= 0);
    if (H5Aexists(o, name) > 0) REQUIRE(H5Adelete(o, name) >= 0);
    hid_t sp = H5Screate(H5S_SCALAR);
    hid_t at = H5Acreate2(o, name, type, sp, H5P_DEFAULT, H5P_DEFAULT);
    REQUIRE(at >= 0);
    REQUIRE(H5Awrite(at, H5T_NATIVE_DOUBLE, &v) >= 0);
    H5Aclose(at);
    H5Sclose(sp);
    H5Oclose(o);
    H5Fclose(f);
}

// Replace dataset `ds_path` by a 1-D float64 dataset of `n` nodes 0, 1, ...
void replace_axis_dataset(const std::string& file, const char* ds_path, hsize_t n) {
    hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    REQUIRE(f >= 0);
    REQUIRE(H5Ldelete(f, ds_path, H5P_DEFAULT) >= 0);
    hid_t sp = H5Screate_simple(1, &n, nullptr);
    hid_t ds = H5Dcreate2(f, ds_path, H5T_IEEE_F64LE, sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    REQUIRE(ds >= 0);
    std::vector<double> nodes(n);
    for (hsize_t k = 0; k < n; ++k) nodes[k] = double(k);
    if (n) REQUIRE(H5Dwrite(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, nodes.data()) >= 0);
    H5Dclose(ds);
    H5Sclose(sp);
    H5Fclose(f);
}

using test::input_error;

bool contains(const std::string& s, const std::string& part) {
    return s.find(part) != std::string::npos;
}

}  // namespace

TEST_CASE("numeric attributes stored as arrays are refused, naming file, object, attribute") {
    fs::path d = scratch_dir("attr_arrays");
    const std::string good = (d / "good.h5").string();
    write_tables(good, {smooth_table(2, 3, 4, StoredType::Float64)});
    struct Case {
        const char* object;
        const char* attr;
        hid_t type;
        hsize_t n;
    };
    // The issue's reproducer (64 x int64 for the format version) and its
    // 2-element variants, which used to overwrite the stack silently.
    const Case cases[] = {{"/", "brdftab_format", H5T_STD_I64LE, 64},
                          {"/", "brdftab_format", H5T_STD_I64LE, 2},
                          {"/brdf", "seed", H5T_STD_U64LE, 2},
                          {"/brdf", "samples_requested", H5T_STD_U64LE, 1000},
                          {"/brdf", "abs_floor", H5T_IEEE_F64LE, 2},
                          {"/brdf", "tolerance_achieved", H5T_IEEE_F64LE, 4096},
                          {"/brdf/theta_i", "min", H5T_IEEE_F64LE, 2},
                          {"/brdf/phi_d", "max", H5T_IEEE_F32LE, 8}};
    for (const Case& c : cases) {
        CAPTURE(c.object);
        CAPTURE(c.attr);
        CAPTURE(c.n);
        const std::string p = (d / "bad.h5").string();
        fs::copy_file(good, p, fs::copy_options::overwrite_existing);
        set_array_attr(p, c.object, c.attr, c.type, c.n, 1.0);
        const std::string msg = input_error([&] { read_table(p, "brdf"); });
        CHECK(contains(msg, p));
        CHECK(contains(msg, std::string("attribute '") + c.attr + "'"));
        CHECK(contains(msg, std::to_string(c.n) + " elements"));
        if (std::string(c.object) != "/") CHECK(contains(msg, c.object));
    }
    // A 1-element array is one value: accepted.
    const std::string p = (d / "one.h5").string();
    fs::copy_file(good, p, fs::copy_options::overwrite_existing);
    set_array_attr(p, "/brdf", "seed", H5T_STD_U64LE, 1, 42.0);
    CHECK(read_table(p, "brdf").seed == 42);
    // Wrong class or sign: a float seed, a negative count.
    set_scalar_attr(p, "/brdf", "seed", H5T_IEEE_F64LE, 42.5);
    CHECK(contains(input_error([&] { read_table(p, "brdf"); }), "attribute 'seed'"));
    set_scalar_attr(p, "/brdf", "seed", H5T_STD_U64LE, 7.0);
    set_scalar_attr(p, "/brdf", "total_samples", H5T_STD_I64LE, -5.0);
    CHECK(contains(input_error([&] { read_table(p, "brdf"); }), "non-negative"));
    // An integer where a double belongs converts exactly: accepted.
    set_scalar_attr(p, "/brdf", "total_samples", H5T_STD_I64LE, 5.0);
    set_scalar_attr(p, "/brdf", "abs_floor", H5T_STD_I32LE, 3.0);
    CHECK(read_table(p, "brdf").abs_floor == 3.0);
    // String attributes: an array of strings where one belongs.
    {
        hid_t f = H5Fopen(p.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
        hid_t g = H5Gopen2(f, "brdf", H5P_DEFAULT);
        H5Adelete(g, "model");
        hid_t st = H5Tcopy(H5T_C_S1);
        H5Tset_size(st, H5T_VARIABLE);
        const hsize_t n = 3;
        hid_t sp = H5Screate_simple(1, &n, nullptr);
        hid_t at = H5Acreate2(g, "model", st, sp, H5P_DEFAULT, H5P_DEFAULT);
        const char* strs[3] = {"a", "b", "c"};
        REQUIRE(H5Awrite(at, st, strs) >= 0);
        H5Aclose(at);
        H5Sclose(sp);
        H5Tclose(st);
        H5Gclose(g);
        H5Fclose(f);
    }
    const std::string msg = input_error([&] { read_table(p, "brdf"); });
    CHECK(contains(msg, "attribute 'model'"));
    CHECK(contains(msg, "3 elements"));
}

TEST_CASE("a cell count that overflows is refused before anything is allocated") {
    fs::path d = scratch_dir("overflow");
    // The issue's table: 4 axes of 65 536 nodes, 2^64 cells (wraps to 0).
    const std::string p = (d / "huge.h5").string();
    {
        hid_t f = H5Fcreate(p.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
        REQUIRE(f >= 0);
        hid_t sp0 = H5Screate(H5S_SCALAR);
        hid_t fa = H5Acreate2(f, "brdftab_format", H5T_STD_I32LE, sp0, H5P_DEFAULT, H5P_DEFAULT);
        const int fmt = 1;
        H5Awrite(fa, H5T_NATIVE_INT, &fmt);
        H5Aclose(fa);
        hid_t g = H5Gcreate2(f, "t", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
        const char* names[4] = {"a", "b", "c", "d"};
        const hsize_t n = 65536;
        std::vector<double> nodes(n);
        for (hsize_t k = 0; k < n; ++k) nodes[k] = double(k);
        for (const char* nm : names) {
            hid_t sp = H5Screate_simple(1, &n, nullptr);
            hid_t ds = H5Dcreate2(g, nm, H5T_IEEE_F64LE, sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
            REQUIRE(ds >= 0);
            H5Dwrite(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, nodes.data());
            H5Dclose(ds);
            H5Sclose(sp);
        }
        hid_t st = H5Tcopy(H5T_C_S1);
        H5Tset_size(st, H5T_VARIABLE);
        hid_t aa = H5Acreate2(g, "axes", st, sp0, H5P_DEFAULT, H5P_DEFAULT);
        const char* axes_json = "[\"a\",\"b\",\"c\",\"d\"]";
        H5Awrite(aa, st, &axes_json);
        H5Aclose(aa);
        H5Tclose(st);
        // The value dataset with the axes' shape: chunked, never written, so
        // the file stays tiny.  (HDF5 may refuse a 2^64-element extent; the
        // reader must refuse the axes either way.)
        const hsize_t dims[4] = {n, n, n, n}, chunk[4] = {1, 1, 1, n};
        hid_t sp = H5Screate_simple(4, dims, nullptr);
        hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
        H5Pset_chunk(dcpl, 4, chunk);
        hid_t v = H5Dcreate2(g, "value", H5T_IEEE_F64LE, sp, H5P_DEFAULT, dcpl, H5P_DEFAULT);
        if (v >= 0) H5Dclose(v);
        H5Eclear2(H5E_DEFAULT);
        H5Pclose(dcpl);
        H5Sclose(sp);
        H5Sclose(sp0);
        H5Gclose(g);
        H5Fclose(f);
    }
    const std::string msg = input_error([&] { read_table(p, "t"); });
    CHECK(contains(msg, p));
    CHECK(contains(msg, "65536 x 65536 x 65536 x 65536"));
    // The helper itself, against the exact product and the wrap-around.
    std::vector<Axis> axes(4);
    for (Axis& a : axes) a.count = 65536;
    CHECK_THROWS_AS(checked_cell_count(axes), InputError);
    axes.pop_back();
    CHECK(checked_cell_count(axes) == (std::size_t(1) << 48));
    CHECK(checked_cell_count({}) == 1);
    // TableData's own count refuses the wrap-around too.
    TableData big;
    big.axes = std::vector<Axis>(4);
    for (Axis& a : big.axes) a.count = 65536;
    CHECK_THROWS_AS(big.cell_count(), InputError);
    big.axes.pop_back();
    CHECK(big.cell_count() == (std::size_t(1) << 48));
}

TEST_CASE("data whose shape differs from the axes is refused") {
    fs::path d = scratch_dir("shape");
    const std::string p = (d / "t.h5").string();
    write_tables(p, {smooth_table(2, 3, 4, StoredType::Float32)});
    hid_t f = H5Fopen(p.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    REQUIRE(H5Ldelete(f, "brdf/stderr", H5P_DEFAULT) >= 0);
    const hsize_t dims[3] = {2, 4, 3};  // same cell count, wrong shape
    hid_t sp = H5Screate_simple(3, dims, nullptr);
    hid_t ds = H5Dcreate2(f, "brdf/stderr", H5T_IEEE_F32LE, sp, H5P_DEFAULT, H5P_DEFAULT,
                          H5P_DEFAULT);
    H5Dclose(ds);
    H5Sclose(sp);
    H5Fclose(f);
    const std::string msg = input_error([&] { read_table(p, "brdf"); });
    CHECK(contains(msg, "'stderr' shape does not match the axes"));
    CHECK(contains(msg, p));
}

TEST_CASE("axes need at least 2 increasing nodes when read, as when written") {
    fs::path d = scratch_dir("short_axes");
    const std::string good = (d / "good.h5").string();
    write_tables(good, {smooth_table(2, 3, 4, StoredType::Float32)});
    for (hsize_t n : {0u, 1u}) {
        CAPTURE(n);
        const std::string p = (d / "bad.h5").string();
        fs::copy_file(good, p, fs::copy_options::overwrite_existing);
        replace_axis_dataset(p, "brdf/phi_d", n);
        const std::string msg = input_error([&] { read_table(p, "brdf"); });
        CHECK(contains(msg, "axis 'phi_d'"));
        CHECK(contains(msg, "at least 2"));
    }
    // Writing such a table is refused too (it could not be read back).
    TableData t = smooth_table(2, 3, 4, StoredType::Float32);
    t.axes[2] = axis("phi_d", "deg", 0, 0, 1);
    t.value.resize(6);
    t.stderr_.resize(6);
    t.samples.resize(6);
    CHECK_THROWS_AS(write_tables((d / "w.h5").string(), {t}), Error);
}

TEST_CASE("axis min/max attributes must agree with the node list") {
    fs::path d = scratch_dir("minmax");
    const std::string p = (d / "t.h5").string();
    TableData t = smooth_table(2, 3, 4, StoredType::Float64);
    write_tables(p, {t});
    // Untouched: the node list's ends, exactly.
    TableData r = read_table(p, "brdf");
    CHECK(r.axes[1].min == t.axes[1].values.front());
    CHECK(r.axes[1].max == t.axes[1].values.back());
    // Tampered max (the issue: it silently changed query results).
    set_scalar_attr(p, "/brdf/theta_i", "max", H5T_IEEE_F64LE, 60.0);
    const std::string msg = input_error([&] { read_table(p, "brdf"); });
    CHECK(contains(msg, "axis 'theta_i'"));
    CHECK(contains(msg, "min/max"));
    CHECK(contains(msg, p));
}

TEST_CASE("a flipped byte inside a dataset is a checksum error, not a wrong value") {
    fs::path d = scratch_dir("fletcher");
    const std::string p = (d / "t.h5").string();
    TableData t;
    t.name = "brdf";
    t.axes = {axis("alpha", "1", 0.1, 0.9, 3), axis("mu", "1", 0.0, 1.0, 4)};
    // Distinctive doubles, stored raw (float64, no compression), so the test
    // can find their bytes in the file without any HDF5 knowledge.
    for (int k = 0; k < 12; ++k) t.value.push_back(0.123456789012345 + k * 1e-3);
    t.stored_type = StoredType::Float64;
    t.compression = 0;
    t.keep_stderr = false;
    write_tables(p, {t});
    CHECK(read_table(p, "brdf").value == t.value);

    std::string bytes = slurp(p);
    std::string needle(sizeof(double), '\0');
    std::memcpy(needle.data(), &t.value[5], sizeof(double));
    const std::size_t at = bytes.find(needle);
    REQUIRE(at != std::string::npos);
    REQUIRE(bytes.find(needle, at + 1) == std::string::npos);
    bytes[at + 3] = static_cast<char>(bytes[at + 3] ^ 0x10);  // one bit of the mantissa
    std::ofstream(p, std::ios::binary | std::ios::trunc) << bytes;

    const std::string msg = input_error([&] { read_table(p, "brdf"); });
    CHECK(contains(msg, p));
    CHECK(contains(msg, "table 'brdf'"));
    CHECK(contains(msg, "value"));

    // The same for the node list of an axis (0.1, 0.5, 0.9: 0.5 is unique).
    write_tables(p, {t});
    bytes = slurp(p);
    const double half = 0.5;
    std::memcpy(needle.data(), &half, sizeof(double));
    const std::size_t at2 = bytes.find(needle);
    REQUIRE(at2 != std::string::npos);
    bytes[at2 + 6] = static_cast<char>(bytes[at2 + 6] ^ 0x01);
    std::ofstream(p, std::ios::binary | std::ios::trunc) << bytes;
    CHECK(contains(input_error([&] { read_table(p, "brdf"); }), "alpha"));
}

TEST_CASE("malformed data is an InputError naming file and table, not an HDF5 Error") {
    fs::path d = scratch_dir("malformed");
    const std::string p = (d / "t.h5").string();
    write_tables(p, {smooth_table(2, 3, 4, StoredType::Float32)});
    // `value` replaced by strings of the right shape: HDF5 cannot convert.
    hid_t f = H5Fopen(p.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    REQUIRE(H5Ldelete(f, "brdf/value", H5P_DEFAULT) >= 0);
    const hsize_t dims[3] = {2, 3, 4};
    hid_t sp = H5Screate_simple(3, dims, nullptr);
    hid_t st = H5Tcopy(H5T_C_S1);
    H5Tset_size(st, 8);
    hid_t ds = H5Dcreate2(f, "brdf/value", st, sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    REQUIRE(ds >= 0);
    H5Dclose(ds);
    H5Tclose(st);
    H5Sclose(sp);
    H5Fclose(f);
    const std::string msg = input_error([&] { read_table(p, "brdf"); });
    CHECK(contains(msg, p));
    CHECK(contains(msg, "table 'brdf'"));
    CHECK(contains(msg, "value"));
    // Not a regular file (a FIFO would block HDF5's probe forever).
    const std::string fifo = (d / "fifo.h5").string();
    fs::remove(fifo);
    REQUIRE(mkfifo(fifo.c_str(), 0600) == 0);
    CHECK(contains(input_error([&] { list_tables(fifo); }), "not a regular file"));
}

TEST_CASE("TableReader reads everything through one open file") {
    fs::path d = scratch_dir("reader");
    const std::string p = (d / "t.h5").string();
    TableData a = smooth_table(2, 3, 4, StoredType::Float64);
    TableData b = a;
    b.name = "albedo";
    write_tables(p, {a, b});
    const TableReader reader(p);
    // Another run replaces the file (atomically, by rename) meanwhile: the
    // open reader keeps seeing the file it opened, whole.
    TableData c = a;
    c.name = "other";
    write_tables(p, {c});
    CHECK(reader.table_names() == std::vector<std::string>{"albedo", "brdf"});
    CHECK(reader.read("albedo").value == a.value);
    CHECK(reader.read("brdf").value == a.value);
    CHECK(reader.file_attributes().contains("brdftab_version"));
    CHECK(list_tables(p) == std::vector<std::string>{"other"});
}

TEST_CASE("string attributes that are not UTF-8 are shown with U+FFFD, not a JSON error") {
    // The fuzzer's finding (tests/fuzz/findings): a damaged `created` held
    // "2026-11-3\x89HDF\r\n", and serialising the attributes threw.
    fs::path d = scratch_dir("utf8");
    const std::string p = (d / "t.h5").string();
    write_tables(p, {smooth_table(2, 2, 2, StoredType::Float32)});
    hid_t f = H5Fopen(p.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    REQUIRE(f >= 0);
    H5Adelete(f, "created");
    const std::string bytes = std::string("2026-11-3\x89HDF\r\n", 15) + "\xCE\xBC";  // + valid µ
    hid_t st = H5Tcopy(H5T_C_S1);
    H5Tset_size(st, bytes.size());
    hid_t sp = H5Screate(H5S_SCALAR);
    hid_t at = H5Acreate2(f, "created", st, sp, H5P_DEFAULT, H5P_DEFAULT);
    REQUIRE(H5Awrite(at, st, bytes.data()) >= 0);
    H5Aclose(at);
    H5Sclose(sp);
    H5Tclose(st);
    H5Fclose(f);
    const nlohmann::json attrs = read_file_attributes(p);
    CHECK_NOTHROW((void)attrs.dump());
    CHECK(attrs["created"].get<std::string>() == "2026-11-3\xEF\xBF\xBDHDF\r\n\xCE\xBC");
}
