// test_exr_export.cpp — EXR slices of an analytic 3-D table, read back with
// OpenEXR's own reader.
//
// Oracles: the analytic function at the node values (cast to float for FLOAT
// channels, within the binary16 rounding bound 2^-11 relative for HALF), the
// header as OpenEXR parses it, and the file system (nothing written on error).
#include <doctest/doctest.h>

#include "test_support.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfInputPart.h>
#include <ImfMultiPartInputFile.h>
#include <ImfStringAttribute.h>
#include <Imath/half.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "host/core/error.h"
#include "host/io/exr_export.h"

namespace fs = std::filesystem;
using namespace brdftab;

namespace {

fs::path scratch_dir(const std::string& sub) { return test::scratch_dir(BT_BINARY_DIR, "test_exr_export", sub); }
using test::axis;
using test::kPi;

double f_value(double a, double th, double ph) {
    return std::exp(-a) * std::cos(th * kPi / 180) * (1.5 + std::sin(ph * kPi / 180)) + 0.01;
}
double f_stderr(double a, double th, double ph) { return 1e-3 * a + 1e-5 * th + 1e-7 * ph; }

// alpha (4) x theta_i (5) x phi_d (6), value/stderr analytic in the node values.
TableData analytic_table() {
    TableData t;
    t.name = "brdf";
    t.model = "test-model";
    t.quantity = "brdf";
    t.units = "1/sr";
    t.axes = {axis("alpha", "1", 0.1, 0.7, 4), axis("theta_i", "deg", 0, 80, 5),
              axis("phi_d", "deg", 0, 150, 6)};
    for (double a : t.axes[0].values)
        for (double th : t.axes[1].values)
            for (double ph : t.axes[2].values) {
                t.value.push_back(f_value(a, th, ph));
                t.stderr_.push_back(f_stderr(a, th, ph));
            }
    return t;
}

struct Image {
    int width = 0, height = 0;
    Imf::PixelType type = Imf::FLOAT;
    std::vector<double> r, g, b, a;
    Imf::Header header;
};

Image read_exr(const std::string& path) {
    Imf::InputFile in(path.c_str());
    Image img;
    img.header = in.header();
    const Imath::Box2i dw = in.header().dataWindow();
    img.width = dw.max.x - dw.min.x + 1;
    img.height = dw.max.y - dw.min.y + 1;
    img.type = in.header().channels().findChannel("R")->type;
    const std::size_t n = std::size_t(img.width) * std::size_t(img.height);
    Imf::FrameBuffer fb;
    std::vector<float> fl[4];
    std::vector<Imath::half> hl[4];
    const char* names[4] = {"R", "G", "B", "A"};
    for (int c = 0; c < 4; ++c) {
        REQUIRE(in.header().channels().findChannel(names[c]) != nullptr);
        REQUIRE(in.header().channels().findChannel(names[c])->type == img.type);
        char* base;
        std::size_t elem;
        if (img.type == Imf::HALF) {
            hl[c].resize(n);
            base = reinterpret_cast<char*>(hl[c].data());
            elem = sizeof(Imath::half);
        } else {
            fl[c].resize(n);
            base = reinterpret_cast<char*>(fl[c].data());
            elem = sizeof(float);
        }
        base -= (std::size_t(dw.min.y) * img.width + dw.min.x) * elem;
        fb.insert(names[c], Imf::Slice(img.type, base, elem, elem * img.width));
    }
    in.setFrameBuffer(fb);
    in.readPixels(dw.min.y, dw.max.y);
    std::vector<double>* out[4] = {&img.r, &img.g, &img.b, &img.a};
    for (int c = 0; c < 4; ++c) {
        out[c]->resize(n);
        for (std::size_t i = 0; i < n; ++i)
            (*out[c])[i] = img.type == Imf::HALF ? double(float(hl[c][i])) : double(fl[c][i]);
    }
    return img;
}

std::string attr(const Imf::Header& h, const char* key) {
    const auto* a = h.findTypedAttribute<Imf::StringAttribute>(key);
    return a ? a->value() : std::string("<missing>");
}

template <class F>
std::string input_error_message(F&& f) {
    try {
        f();
    } catch (const InputError& e) {
        return e.what();
    } catch (...) {
        return "<other exception>";
    }
    return "<no exception>";
}

}  // namespace

TEST_CASE("FLOAT slice equals the analytic table at the nodes") {
    fs::path d = scratch_dir("float");
    TableData t = analytic_table();
    ExrExportOptions o;
    o.slice["theta_i"] = 40.0;  // node 2 of 0, 20, 40, 60, 80
    const std::string out = (d / "s.exr").string();
    export_exr_slice(t, out, o);

    Image img = read_exr(out);
    CHECK(img.type == Imf::FLOAT);
    CHECK(img.header.compression() == Imf::ZIP_COMPRESSION);
    CHECK(img.width == 6);   // x = last free axis (phi_d)
    CHECK(img.height == 4);  // y = first free axis (alpha)
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const double a = t.axes[0].values[y], ph = t.axes[2].values[x];
            const std::size_t p = std::size_t(y) * img.width + x;
            CHECK(img.r[p] == double(float(f_value(a, 40.0, ph))));
            CHECK(img.g[p] == double(float(f_stderr(a, 40.0, ph))));
            CHECK(img.b[p] == 0.0);
            CHECK(img.a[p] == 1.0);
        }
    CHECK(attr(img.header, "brdftab_table") == "brdf");
    CHECK(attr(img.header, "brdftab_x_axis").find("phi_d") == 0);
    CHECK(attr(img.header, "brdftab_x_axis").find("[0, 150]") != std::string::npos);
    CHECK(attr(img.header, "brdftab_y_axis").find("alpha") == 0);
    CHECK(attr(img.header, "brdftab_slice") == "theta_i=40 deg");
    CHECK(attr(img.header, "brdftab_channels") == "R=value G=stderr B=0 A=1");
    CHECK(std::vector<std::string>{"s.exr"} ==
          std::vector<std::string>{fs::directory_iterator(d)->path().filename().string()});
}

TEST_CASE("HALF slice is within binary16 rounding of the table") {
    fs::path d = scratch_dir("half");
    TableData t = analytic_table();
    ExrExportOptions o;
    o.half = true;
    o.with_stderr = false;
    o.slice["phi_d"] = 90.0;  // node 3 of 0, 30, ..., 150
    const std::string out = (d / "h.exr").string();
    export_exr_slice(t, out, o);

    Image img = read_exr(out);
    CHECK(img.type == Imf::HALF);
    CHECK(img.width == 5);   // theta_i
    CHECK(img.height == 4);  // alpha
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const double v = f_value(t.axes[0].values[y], t.axes[1].values[x], 90.0);
            const std::size_t p = std::size_t(y) * img.width + x;
            // Values here are normal halves (>= 2^-14): rounding error <= 2^-11 relative.
            CHECK(std::fabs(img.r[p] - v) <= std::ldexp(std::fabs(v), -11));
            CHECK(img.g[p] == 0.0);  // with_stderr = false
            CHECK(img.a[p] == 1.0);
        }
    CHECK(attr(img.header, "brdftab_channels") == "R=value G=0 B=0 A=1");
}

TEST_CASE("no slice needed when only two axes have more than one node") {
    fs::path d = scratch_dir("two");
    TableData t;
    t.name = "albedo";
    t.axes = {axis("eta", "1", 1.5, 1.5, 1), axis("alpha", "1", 0.1, 0.9, 3),
              axis("mu_i", "1", 0.0, 1.0, 5)};
    for (double a : t.axes[1].values)
        for (double mu : t.axes[2].values) t.value.push_back(a * 10 + mu);
    const std::string out = (d / "a.exr").string();
    export_exr_slice(t, out, {});
    Image img = read_exr(out);
    CHECK(img.width == 5);
    CHECK(img.height == 3);
    CHECK(img.r[1 * 5 + 4] == double(float(0.5 * 10 + 1.0)));
    CHECK(img.g[0] == 0.0);  // no stderr in the table

    // The size-1 axis may be named, with its node; near-equal values count.
    ExrExportOptions o;
    o.slice["eta"] = 1.5 * (1 + 1e-12);
    export_exr_slice(t, out, o);
    o.slice["eta"] = 1.6;
    CHECK(input_error_message([&] { export_exr_slice(t, out, o); }).find("eta") !=
          std::string::npos);
}

TEST_CASE("bad slices are InputErrors and write nothing") {
    fs::path d = scratch_dir("errors");
    TableData t = analytic_table();
    const std::string out = (d / "x.exr").string();

    ExrExportOptions o;
    o.slice["theta_i"] = 95.0;  // beyond the last node
    std::string msg = input_error_message([&] { export_exr_slice(t, out, o); });
    CHECK(msg.find("95") != std::string::npos);
    CHECK(msg.find("80") != std::string::npos);

    // Three free axes: the message lists the axes that could be fixed.
    msg = input_error_message([&] { export_exr_slice(t, out, {}); });
    CHECK(msg.find("alpha") != std::string::npos);
    CHECK(msg.find("theta_i") != std::string::npos);
    CHECK(msg.find("phi_d") != std::string::npos);

    // One free axis.
    o.slice = {{"theta_i", 20.0}, {"phi_d", 30.0}};
    msg = input_error_message([&] { export_exr_slice(t, out, o); });
    CHECK(msg.find("two free axes") != std::string::npos);

    // Unknown axis name: lists the real ones.
    o.slice = {{"theta_o", 20.0}};
    msg = input_error_message([&] { export_exr_slice(t, out, o); });
    CHECK(msg.find("theta_o") != std::string::npos);
    CHECK(msg.find("alpha, theta_i, phi_d") != std::string::npos);

    CHECK(fs::is_empty(d));  // neither the image nor a temporary file

    // An existing image survives a failed export byte for byte.
    ExrExportOptions good;
    good.slice["alpha"] = 0.1;
    export_exr_slice(t, out, good);
    auto slurp = [&] {
        std::ifstream f(out, std::ios::binary);
        return std::string(std::istreambuf_iterator<char>(f), {});
    };
    const std::string before = slurp();
    o.slice = {{"alpha", 0.05}};  // below the axis
    CHECK_THROWS_AS(export_exr_slice(t, out, o), InputError);
    CHECK(slurp() == before);
    CHECK(std::distance(fs::directory_iterator(d), fs::directory_iterator{}) == 1);
}

TEST_CASE("a slice between nodes is interpolated linearly, and a note says so") {
    // theta_i = 33 lies between the nodes 20 and 40 of a linear axis: each
    // pixel is 0.35 f(20) + 0.65 f(40) (value and stderr), the library's
    // linear weights, computed here from the analytic function.
    fs::path d = scratch_dir("between");
    TableData t = analytic_table();
    const std::string out = (d / "between.exr").string();
    ExrExportOptions o;
    o.slice["theta_i"] = 33.0;
    const std::vector<std::string> notes = export_exr_slice(t, out, o);
    REQUIRE(notes.size() == 1);
    CHECK(notes[0].find("theta_i = 33 deg is not a node") != std::string::npos);
    CHECK(notes[0].find("between the nodes 20 and 40") != std::string::npos);
    CHECK(notes[0].find("interpolated linearly") != std::string::npos);
    const Image img = read_exr(out);
    CHECK(img.width == 6);   // phi_d on x
    CHECK(img.height == 4);  // alpha on y
    const double s = 13.0 / 20.0;
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 6; ++x) {
            const double a = t.axes[0].values[y], ph = t.axes[2].values[x];
            const double v = (1 - s) * f_value(a, 20, ph) + s * f_value(a, 40, ph);
            const double e = (1 - s) * f_stderr(a, 20, ph) + s * f_stderr(a, 40, ph);
            CHECK(img.r[y * 6 + x] == doctest::Approx(v).epsilon(1e-7));
            CHECK(img.g[y * 6 + x] == doctest::Approx(e).epsilon(1e-7));
        }
    CHECK(attr(img.header, "brdftab_slice") == "theta_i=33 deg (interpolated)");
    // At a node: no note, the node's values exactly.
    o.slice["theta_i"] = 40.0;
    CHECK(export_exr_slice(t, out, o).empty());
}

TEST_CASE("unwritable output is an Error, not a crash") {
    fs::path d = scratch_dir("nodir");
    TableData t = analytic_table();
    ExrExportOptions o;
    o.slice["alpha"] = 0.3;
    CHECK_THROWS_AS(export_exr_slice(t, (d / "missing" / "x.exr").string(), o), Error);
    CHECK(fs::is_empty(d));
}

TEST_CASE("an axis without nodes is an InputError, not a crash") {
    // #15: `export` on a table with a 0-node axis took .front() of an empty
    // node list.  (The reader refuses such files; this guards in-memory use.)
    fs::path d = scratch_dir("empty_axis");
    TableData t;
    t.name = "albedo";
    t.axes = {axis("alpha", "1", 0.1, 0.9, 3), axis("mu_i", "1", 0.0, 1.0, 5)};
    Axis empty;
    empty.name = "eta";
    t.axes.insert(t.axes.begin(), empty);
    ExrExportOptions o;
    o.slice["eta"] = 1.5;
    CHECK(input_error_message([&] { export_exr_slice(t, (d / "a.exr").string(), o); })
              .find("'eta' has no nodes") != std::string::npos);
}

// ---- issue 16: --layers, --axes, --no-stderr, the version attribute.

namespace {

// All parts of a (multi-part) file, R and G as float, with their headers.
struct PartImage {
    std::string name;
    int width = 0, height = 0;
    std::vector<float> r, g;
    Imf::Header header;
};

std::vector<PartImage> read_parts(const std::string& path) {
    Imf::MultiPartInputFile file(path.c_str());
    std::vector<PartImage> parts;
    for (int k = 0; k < file.parts(); ++k) {
        Imf::InputPart in(file, k);
        PartImage p;
        p.header = in.header();
        p.name = in.header().hasName() ? in.header().name() : "";
        const Imath::Box2i dw = in.header().dataWindow();
        p.width = dw.max.x - dw.min.x + 1;
        p.height = dw.max.y - dw.min.y + 1;
        const std::size_t n = std::size_t(p.width) * std::size_t(p.height);
        p.r.resize(n);
        p.g.resize(n);
        Imf::FrameBuffer fb;
        const std::size_t off = std::size_t(dw.min.y) * p.width + dw.min.x;
        // Read as FLOAT whatever the channel type (OpenEXR converts).
        fb.insert("R", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(p.r.data() - off),
                                  sizeof(float), sizeof(float) * p.width));
        fb.insert("G", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(p.g.data() - off),
                                  sizeof(float), sizeof(float) * p.width));
        in.setFrameBuffer(fb);
        in.readPixels(dw.min.y, dw.max.y);
        parts.push_back(std::move(p));
    }
    return parts;
}

}  // namespace

TEST_CASE("--layers: one part per node of the third free axis, --axes picks x and y") {
    fs::path d = scratch_dir("layers");
    const TableData t = analytic_table();  // alpha (4) x theta_i (5) x phi_d (6)
    ExrExportOptions o;
    o.layers = true;
    o.x_axis = "theta_i";  // x and y swapped against the table's order
    o.y_axis = "phi_d";
    const std::string out = (d / "l.exr").string();
    export_exr_slice(t, out, o);
    const std::vector<PartImage> parts = read_parts(out);
    REQUIRE(parts.size() == 4);  // the alpha nodes
    for (std::size_t l = 0; l < parts.size(); ++l) {
        const PartImage& p = parts[l];
        const double a = t.axes[0].values[l];
        char name[32];
        std::snprintf(name, sizeof name, "alpha=%g", a);
        CHECK(p.name == name);
        CHECK(p.width == 5);
        CHECK(p.height == 6);
        for (int y = 0; y < p.height; ++y)
            for (int x = 0; x < p.width; ++x) {
                const double th = t.axes[1].values[x], ph = t.axes[2].values[y];
                const std::size_t i = std::size_t(y) * p.width + x;
                CHECK(p.r[i] == float(f_value(a, th, ph)));
                CHECK(p.g[i] == float(f_stderr(a, th, ph)));
            }
        CHECK(attr(p.header, "brdftab_x_axis").find("theta_i") == 0);
        CHECK(attr(p.header, "brdftab_y_axis").find("phi_d") == 0);
        CHECK(attr(p.header, "brdftab_layer_axis").find("alpha") == 0);
        CHECK(attr(p.header, "brdftab_slice") == std::string(name));
    }
    // A fixed axis leaves two free: --layers needs three.
    o.slice["alpha"] = 0.3;
    CHECK(input_error_message([&] { export_exr_slice(t, (d / "x.exr").string(), o); })
              .find("three free axes") != std::string::npos);
    CHECK(!fs::exists(d / "x.exr"));
}

TEST_CASE("--axes on a 2-D slice, --no-stderr, and the real version") {
    fs::path d = scratch_dir("axes");
    const TableData t = analytic_table();
    ExrExportOptions o;
    o.slice["theta_i"] = 20.0;
    o.x_axis = "alpha";  // UE4-style: the table's first axis on x
    o.y_axis = "phi_d";
    o.with_stderr = false;
    const std::string out = (d / "a.exr").string();
    export_exr_slice(t, out, o);
    const std::vector<PartImage> parts = read_parts(out);
    REQUIRE(parts.size() == 1);
    const PartImage& p = parts[0];
    CHECK(p.width == 4);
    CHECK(p.height == 6);
    for (int y = 0; y < p.height; ++y)
        for (int x = 0; x < p.width; ++x) {
            const std::size_t i = std::size_t(y) * p.width + x;
            CHECK(p.r[i] == float(f_value(t.axes[0].values[x], 20.0, t.axes[2].values[y])));
            CHECK(p.g[i] == 0.0f);
        }
    CHECK(attr(p.header, "brdftab_channels") == "R=value G=0 B=0 A=1");
    CHECK(attr(p.header, "brdftab_version") == BRDFTAB_VERSION);
    CHECK(attr(p.header, "brdftab_version") != "unknown");
    // An image axis that is fixed, or not an axis, is named in the error.
    o.x_axis = "theta_i";
    CHECK(input_error_message([&] { export_exr_slice(t, (d / "x.exr").string(), o); })
              .find("'theta_i' (image x) is not a free axis") != std::string::npos);
    o.x_axis = "phi_d";
    CHECK(input_error_message([&] { export_exr_slice(t, (d / "x.exr").string(), o); })
              .find("twice") != std::string::npos);
    CHECK(!fs::exists(d / "x.exr"));
}

TEST_CASE("two-channel texture: G = a second table on the same grid") {
    fs::path d = scratch_dir("green");
    const TableData t = analytic_table();
    TableData second = t;
    second.name = "second";
    for (std::size_t k = 0; k < second.value.size(); ++k) second.value[k] = 0.25 + 1e-3 * double(k);
    ExrExportOptions o;
    o.slice["theta_i"] = 40.0;
    o.green = &second;
    const std::string out = (d / "rg.exr").string();
    export_exr_slice(t, out, o);
    const Image img = read_exr(out);
    REQUIRE(img.width == 6);
    REQUIRE(img.height == 4);
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const std::size_t i = std::size_t(y) * img.width + x;
            const std::size_t c = (std::size_t(y) * 5 + 2) * 6 + std::size_t(x);  // alpha y, theta_i node 2, phi_d x
            CHECK(img.r[i] == float(t.value[c]));
            CHECK(img.g[i] == float(second.value[c]));
        }
    CHECK(attr(img.header, "brdftab_channels") == "R=brdf G=second B=0 A=1");
    // A second table on other nodes is refused and nothing is written.
    TableData other = second;
    other.axes[0] = axis("alpha", "1", 0.1, 0.9, 4);
    o.green = &other;
    CHECK(input_error_message([&] { export_exr_slice(t, (d / "bad.exr").string(), o); })
              .find("share one grid") != std::string::npos);
    CHECK(!fs::exists(d / "bad.exr"));
}
