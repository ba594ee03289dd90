// material_mapping.cpp — a renderer's material in brdftab's terms.
//
// Each mapping uses the renderer's own conventions (docs/scenes.md has the
// table with the source of each):
//   pbrt-v4 dielectric      -> rough-dielectric, GGX, alpha = sqrt(roughness)
//                              when remaproughness (default), height-correlated
//                              Smith G (pbrt-v4's TrowbridgeReitz G)
//   pbrt-v4 coateddiffuse   -> interfaced-lambertian, ggx-smith, ni = eta,
//                              Kd = reflectance factored out (approximation:
//                              pbrt's layered random walk is not this model);
//                              uroughness != vroughness -> alpha_x, alpha_y
//   pbrt-v3 matte (sigma>0) -> oren-nayar, sigma in degrees, rho = Kd factored
//   pbrt-v3 glass           -> rough-dielectric, GGX, pbrt-v3's roughness remap,
//                              height-correlated Smith G
//   Mitsuba roughdielectric -> rough-dielectric, beckmann (default) or ggx,
//                              separable Smith G1 G1, eta = int_ior / ext_ior
//   Mitsuba roughplastic    -> interfaced-lambertian, beckmann-smith or
//                              ggx-smith, ni = int_ior / ext_ior, Kd factored
//   Mitsuba 0.6 roughdiffuse-> oren-nayar, sigma = alpha / sqrt(2) radians
#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include "host/core/error.h"
#include "host/models/registry.h"
#include "host/scene/scene.h"

namespace brdftab {

const char* to_string(MaterialStatus status) {
    switch (status) {
        case MaterialStatus::Tabulated: return "tabulated";
        case MaterialStatus::NoTableNeeded: return "no-table-needed";
        case MaterialStatus::Unsupported: return "unsupported";
    }
    return "unsupported";
}

double pbrt_v4_roughness_to_alpha(double roughness) { return std::sqrt(std::max(roughness, 0.0)); }

double pbrt_v3_roughness_to_alpha(double roughness) {
    // pbrt-v3 TrowbridgeReitzDistribution::RoughnessToAlpha: a quartic in
    // x = log(roughness), roughness clamped below at 1e-3.
    const double x = std::log(std::max(roughness, 1e-3));
    return 1.62142 + 0.819955 * x + 0.1734 * x * x + 0.0171201 * x * x * x +
           0.000640711 * x * x * x * x;
}

std::optional<double> mitsuba_named_ior(const std::string& name) {
    // Mitsuba's table of named indices of refraction (include/mitsuba/render/ior.h).
    static const std::map<std::string, double> table = {
        {"vacuum", 1.0},           {"helium", 1.000036},          {"hydrogen", 1.000132},
        {"air", 1.000277},         {"carbon dioxide", 1.00045},   {"water", 1.3330},
        {"acetone", 1.36},         {"ethanol", 1.361},            {"carbon tetrachloride", 1.461},
        {"glycerol", 1.4729},      {"benzene", 1.501},            {"silicone oil", 1.52045},
        {"bromine", 1.661},        {"water ice", 1.31},           {"fused quartz", 1.458},
        {"pyrex", 1.470},          {"acrylic glass", 1.49},       {"polypropylene", 1.49},
        {"bk7", 1.5046},           {"sodium chloride", 1.544},    {"amber", 1.55},
        {"pet", 1.5750},           {"diamond", 2.419}};
    std::string key = name;
    std::transform(key.begin(), key.end(), key.begin(), ::tolower);
    auto it = table.find(key);
    if (it == table.end()) return std::nullopt;
    return it->second;
}

namespace {

std::string fmt(double v) {
    std::ostringstream s;
    s.precision(10);
    s << v;
    return s.str();
}

// A scalar parameter as the material gives it: a number, or the range of an
// image texture (possibly missing).
struct Value {
    bool given = false;
    bool ranged = false;
    double value = 0, lo = 0, hi = 0;
    bool missing_image = false;
    std::string image;
    std::string where;

    template <class F>
    Value map(F f) const {
        Value v = *this;
        v.value = f(value);
        v.lo = f(lo);
        v.hi = f(hi);
        if (v.lo > v.hi) std::swap(v.lo, v.hi);
        return v;
    }
};

class Reader {
public:
    explicit Reader(const SceneMaterial& m) : m_(m) {}

    std::string label() const {
        return "material '" + m_.name + "' (" + m_.type + ", " + m_.where + ")";
    }

    bool has(const std::string& name) const { return m_.parameters.count(name) != 0; }

    Value number(const std::string& name, double fallback) const {
        Value v;
        v.value = fallback;
        auto it = m_.parameters.find(name);
        if (it == m_.parameters.end()) return v;
        const SceneParameter& p = it->second;
        v.given = true;
        v.where = p.where;
        if (p.image) {
            v.ranged = true;
            v.image = *p.image;
            v.missing_image = p.image_missing;
            v.lo = p.image_min;
            v.hi = p.image_max;
            v.value = 0.5 * (v.lo + v.hi);
            return v;
        }
        if (!p.numbers.empty()) {
            v.value = p.numbers[0];
            return v;
        }
        if (p.type == "texture")
            throw InputError(label() + ": parameter '" + name + "' refers to texture '" +
                             (p.texts.empty() ? std::string() : p.texts[0]) +
                             "', which the scene does not define as a float texture");
        throw InputError(label() + ": parameter '" + name + "' must be a number (" + p.where +
                         ")");
    }

    // An index of refraction: a number or (Mitsuba) a named material.
    Value ior(const std::string& name, const std::string& fallback_name) const {
        auto it = m_.parameters.find(name);
        if (it != m_.parameters.end() && !it->second.texts.empty() && it->second.numbers.empty()) {
            const std::string& s = it->second.texts[0];
            auto v = mitsuba_named_ior(s);
            if (!v)
                throw InputError(label() + ": parameter '" + name + "': unknown named IOR '" + s +
                                 "' (" + it->second.where + ")");
            Value out;
            out.given = true;
            out.value = *v;
            return out;
        }
        if (it != m_.parameters.end()) return number(name, 0);
        Value out;
        out.value = *mitsuba_named_ior(fallback_name);
        return out;
    }

    std::string text(const std::string& name, const std::string& fallback) const {
        auto it = m_.parameters.find(name);
        if (it == m_.parameters.end() || it->second.texts.empty()) return fallback;
        return it->second.texts[0];
    }

    bool flag(const std::string& name, bool fallback) const {
        const std::string t = text(name, fallback ? "true" : "false");
        if (t == "true") return true;
        if (t == "false") return false;
        throw InputError(label() + ": parameter '" + name + "' must be true or false, not '" + t +
                         "'");
    }

    // A reflectance-like parameter factored out of the table: its numbers
    // (one value or rgb) or the texture it names.
    nlohmann::json factor(const std::string& name, double fallback) const {
        auto it = m_.parameters.find(name);
        if (it == m_.parameters.end()) return fallback;
        const SceneParameter& p = it->second;
        if (p.image) return {{"texture", *p.image}};
        if (p.numbers.size() == 1) return p.numbers[0];
        if (!p.numbers.empty()) return p.numbers;
        if (!p.texts.empty()) return {{"texture", p.texts[0]}};
        return fallback;
    }

private:
    const SceneMaterial& m_;
};

class Mapper {
public:
    explicit Mapper(const SceneMaterial& m) : r_(m) {
        out_.source = m;
    }

    MappedMaterial no_table(const std::string& reason) {
        out_.status = MaterialStatus::NoTableNeeded;
        out_.reason = reason;
        return out_;
    }
    MappedMaterial unsupported(const std::string& reason) {
        out_.status = MaterialStatus::Unsupported;
        out_.reason = reason;
        return out_;
    }

    // Sets a brdftab parameter after checking it against the model's range.
    void set(const std::string& name, const Value& v) {
        const ModelInfo& model = find_model(out_.model);
        const ParameterInfo* info = model.find_parameter(name);
        if (!info) throw std::logic_error("scene mapping: no parameter " + name);
        if (!v.ranged) {
            if (!info->accepts(v.value))
                throw InputError(r_.label() + ": " + name + " = " + fmt(v.value) +
                                 " is outside the range of brdftab's " + out_.model + " model, " +
                                 info->range_text());
            out_.parameters[name] = v.value;
            return;
        }
        double lo = v.lo, hi = v.hi;
        if (v.missing_image) {
            // No image to read: the model's whole range (open ends nudged in).
            lo = info->min_inclusive ? info->min : info->min + 1e-3 * (info->max - info->min);
            hi = info->max_inclusive ? info->max : info->max - 1e-3 * (info->max - info->min);
            if (name == "alpha") lo = std::max(lo, 1e-3);
            out_.notes.push_back("texture " + v.image + " for " + name +
                                 " could not be read (missing or procedural): the table spans "
                                 "the model's whole range of " +
                                 name + ", [" + fmt(lo) + ", " + fmt(hi) + "]");
        } else {
            for (double e : {lo, hi})
                if (!info->accepts(e))
                    throw InputError(r_.label() + ": " + name + " from texture " + v.image +
                                     " reaches " + fmt(e) + ", outside the range of brdftab's " +
                                     out_.model + " model, " + info->range_text());
            out_.notes.push_back(name + " comes from texture " + v.image + " (values in [" +
                                 fmt(lo) + ", " + fmt(hi) + "]): a table axis");
        }
        if (hi - lo <= 1e-12 * std::max(1.0, std::fabs(hi))) {
            out_.parameters[name] = lo;  // a constant image
        } else {
            out_.parameter_ranges[name] = {lo, hi};
        }
    }

    void tabulated(const std::string& model, const std::string& reason) {
        out_.status = MaterialStatus::Tabulated;
        out_.model = model;
        out_.reason = reason;
    }

    MappedMaterial result() { return out_; }

    const Reader& r() const { return r_; }
    MappedMaterial& out() { return out_; }

private:
    Reader r_;
    MappedMaterial out_;
};

// Smooth below this alpha: a table cannot hold a lobe that narrow, and the
// renderers switch to their perfectly specular code paths there too (pbrt-v4
// treats alpha < 1e-3 as "effectively smooth").
constexpr double kSmoothAlpha = 1e-3;

bool effectively_smooth(const Value& alpha) {
    return !alpha.ranged && alpha.value < kSmoothAlpha;
}

// Roughness of pbrt's dielectric-like materials: alpha along u (the
// shading frame's dpdu, pbrt's alpha_x) and, in `alpha_v`, along v (alpha_y),
// both remapped; `anisotropic` when they differ.
Value pbrt_alpha(const Reader& r, bool v4, bool& anisotropic, Value* alpha_v = nullptr) {
    const bool remap = r.flag("remaproughness", true);
    const Value rough = r.number("roughness", 0);
    Value u = r.has("uroughness") ? r.number("uroughness", 0) : rough;
    Value v = r.has("vroughness") ? r.number("vroughness", 0) : rough;
    anisotropic = u.ranged || v.ranged ? (u.image != v.image)
                                       : std::fabs(u.value - v.value) > 1e-12;
    if (remap) {
        u = v4 ? u.map(pbrt_v4_roughness_to_alpha) : u.map(pbrt_v3_roughness_to_alpha);
        v = v4 ? v.map(pbrt_v4_roughness_to_alpha) : v.map(pbrt_v3_roughness_to_alpha);
    }
    if (alpha_v) *alpha_v = v;
    return u;
}

MappedMaterial map_pbrt(const SceneMaterial& m) {
    Mapper mp(m);
    const Reader& r = mp.r();
    const std::string& t = m.type;
    if (t == "dielectric" || t == "glass") {
        const bool v4 = t == "dielectric";
        bool aniso = false;
        const Value alpha = pbrt_alpha(r, v4, aniso);
        if (aniso)
            return mp.unsupported("anisotropic roughness (uroughness != vroughness): brdftab's "
                                  "rough-dielectric model is isotropic (one alpha, no alpha_x / "
                                  "alpha_y)");
        Value eta;
        if (v4) {
            auto it = m.parameters.find("eta");
            if (it != m.parameters.end() && it->second.numbers.empty() &&
                !it->second.texts.empty())
                return mp.unsupported("eta is the named spectrum '" + it->second.texts[0] +
                                      "' (dispersion); give a float eta to tabulate it");
            eta = r.number("eta", 1.5);
        } else {
            eta = r.number("index", 1.5);
        }
        if (effectively_smooth(alpha))
            return mp.no_table("smooth interface (alpha = " + fmt(alpha.value) +
                               " after remapping, below 1e-3): the renderer's perfectly specular "
                               "path uses closed-form Fresnel reflection and refraction");
        if (!eta.ranged && eta.value == 1.0)
            return mp.no_table("eta = 1: an index-matched interface does not scatter");
        mp.tabulated("rough-dielectric",
                     std::string("pbrt-") + (v4 ? "v4" : "v3") +
                         " rough dielectric: GGX (Trowbridge-Reitz) with height-correlated Smith "
                         "masking-shadowing, " +
                         (r.flag("remaproughness", true)
                              ? (v4 ? "alpha = sqrt(roughness)" : "pbrt-v3's roughness-to-alpha remap")
                              : "alpha = roughness (remaproughness false)"));
        mp.set("alpha", alpha);
        mp.set("eta", eta);
        mp.out().options = {{"distribution", "ggx"}, {"g1", "smith"},
                            {"shadowing", "height-correlated"}};
        if (!v4) {
            mp.out().factored = {{"kr", r.factor("Kr", 1)}, {"kt", r.factor("Kt", 1)}};
        }
        return mp.result();
    }
    if (t == "coateddiffuse") {
        bool aniso = false;
        Value alpha_v;
        const Value alpha = pbrt_alpha(r, true, aniso, &alpha_v);
        if (aniso && (alpha.ranged || alpha_v.ranged))
            return mp.unsupported("anisotropic coating roughness from textures: two texture axes "
                                  "on a four-angle table are not supported; give numbers");
        if (effectively_smooth(alpha) || (aniso && effectively_smooth(alpha_v)))
            return mp.unsupported("smooth coating (alpha below 1e-3): the interfaced-Lambertian "
                                  "model describes rough facets only");
        mp.tabulated("interfaced-lambertian",
                     "pbrt-v4 coateddiffuse, approximated by interfaced Lambertian microfacets "
                     "(GGX + Smith, ni = eta, Kd = reflectance)");
        mp.out().notes.push_back("approximation: pbrt simulates a layer with a random walk "
                                 "between a dielectric interface and a diffuse base; this "
                                 "model makes every facet an interface over a Lambertian "
                                 "substrate");
        if (aniso) {
            // pbrt-v4's TrowbridgeReitzDistribution(alpha_x = u, alpha_y = v),
            // x along dpdu: the model's alpha_x / alpha_y, azimuths from x.
            mp.set("alpha_x", alpha);
            mp.set("alpha_y", alpha_v);
            mp.out().notes.push_back("anisotropic: alpha_x along the shading frame's u (dpdu), "
                                     "alpha_y along v; the tables have phi_i and phi_o axes "
                                     "measured from u");
        } else {
            mp.set("alpha", alpha);
        }
        mp.set("ni", r.number("eta", 1.5));
        mp.out().options = {{"distribution", "ggx-smith"}, {"sampling", "visible"}};
        mp.out().factored = {{"kd", r.factor("reflectance", 0.5)}};
        if (r.number("albedo", 0).value != 0 || r.has("g"))
            mp.out().notes.push_back("the coating's medium (albedo, g, thickness) is ignored");
        return mp.result();
    }
    if (t == "matte") {
        const Value sigma = r.number("sigma", 0);
        if (!sigma.ranged && sigma.value == 0)
            return mp.no_table("sigma = 0: Lambertian, a closed form");
        mp.tabulated("oren-nayar",
                     "pbrt-v3 matte with sigma > 0: pbrt renders the Oren-Nayar functional "
                     "approximation; the table holds the exact V-cavity model (same sigma in "
                     "degrees), with rho = Kd factored out");
        mp.set("sigma", sigma);
        mp.out().factored = {{"rho", r.factor("Kd", 0.5)}};
        return mp.result();
    }
    if (t == "plastic")
        return mp.unsupported("pbrt-v3 plastic adds a Lambertian lobe and a microfacet reflection "
                              "lobe with no coupling between them; both lobes are closed forms, "
                              "and it is not the interfaced-Lambertian model");
    if (t == "diffuse") return mp.no_table("Lambertian: a closed form");
    if (t == "interface") return mp.no_table("marks a boundary between media; it does not scatter");
    if (t == "mirror") return mp.no_table("perfect mirror: a closed form");
    if (t == "thindielectric") return mp.no_table("smooth thin dielectric: closed-form Fresnel");
    if (t == "measured") return mp.unsupported("measured data is a table already");
    if (t == "conductor" || t == "metal" || t == "coatedconductor")
        return mp.unsupported("brdftab has no conductor model (a rough conductor's single "
                              "scattering is a closed form in the renderer)");
    if (t == "mix") return mp.unsupported("a mixture of materials; its named parts are listed "
                                          "on their own");
    return mp.unsupported("no brdftab model for pbrt material type '" + t + "'");
}

MappedMaterial map_mitsuba(const SceneMaterial& m) {
    Mapper mp(m);
    const Reader& r = mp.r();
    const std::string& t = m.type;
    const bool legacy = m.format == "mitsuba-0.6";
    if (m.wrapped_in.rfind("ref:", 0) == 0)
        return mp.no_table("wraps the BSDF '" + m.wrapped_in.substr(4) +
                           "', which carries the table");
    auto eta_of = [&](const char* int_default, double& eta) -> Value {
        Value in = r.ior("int_ior", int_default);
        Value ex = r.ior("ext_ior", "air");
        Value v;
        v.given = true;
        v.value = in.value / ex.value;
        eta = v.value;
        return v;
    };
    auto alpha_of = [&](bool& aniso) -> Value {
        const Value a = r.number("alpha", 0.1);
        const Value au = r.has("alpha_u") ? r.number("alpha_u", 0.1) : a;
        const Value av = r.has("alpha_v") ? r.number("alpha_v", 0.1) : a;
        aniso = au.ranged || av.ranged ? au.image != av.image
                                       : std::fabs(au.value - av.value) > 1e-12;
        return au;
    };
    if (t == "roughdielectric") {
        const std::string dist = r.text("distribution", "beckmann");
        if (dist != "beckmann" && dist != "ggx" && !(legacy && dist == "phong"))
            return mp.unsupported("microfacet distribution '" + dist +
                                  "' (brdftab has beckmann, ggx and phong)");
        bool aniso = false;
        const Value alpha = alpha_of(aniso);
        if (aniso)
            return mp.unsupported("anisotropic roughness (alpha_u != alpha_v): brdftab's "
                                  "rough-dielectric model is isotropic (one alpha, no alpha_x / "
                                  "alpha_y)");
        double eta_value = 0;
        const Value eta = eta_of("bk7", eta_value);
        if (effectively_smooth(alpha))
            return mp.no_table("alpha below 1e-3: effectively a smooth dielectric");
        if (eta_value == 1.0) return mp.no_table("eta = 1: an index-matched interface does not scatter");
        mp.tabulated("rough-dielectric",
                     "Mitsuba roughdielectric: " + dist +
                         " with the separable Smith masking-shadowing G1(i) G1(o), eta = "
                         "int_ior / ext_ior");
        mp.set("alpha", alpha);
        mp.set("eta", eta);
        mp.out().options = {{"distribution", dist}, {"g1", "smith"}, {"shadowing", "separable"}};
        if (r.has("specular_reflectance") || r.has("specular_transmittance"))
            mp.out().factored = {{"specular_reflectance", r.factor("specular_reflectance", 1)},
                                 {"specular_transmittance", r.factor("specular_transmittance", 1)}};
        return mp.result();
    }
    if (t == "roughplastic") {
        const std::string dist = r.text("distribution", "beckmann");
        if (dist != "beckmann" && dist != "ggx")
            return mp.unsupported("microfacet distribution '" + dist +
                                  "' (interfaced-lambertian has beckmann and ggx)");
        bool aniso = false;
        const Value alpha = alpha_of(aniso);
        if (r.has("alpha_u") || r.has("alpha_v"))
            return mp.unsupported("alpha_u / alpha_v are not parameters of Mitsuba's roughplastic, "
                                  "which is isotropic (alpha only)");
        if (effectively_smooth(alpha))
            return mp.unsupported("alpha below 1e-3: the interfaced-Lambertian model describes "
                                  "rough facets only");
        double eta_value = 0;
        const Value ni = eta_of("polypropylene", eta_value);
        mp.tabulated("interfaced-lambertian",
                     "Mitsuba roughplastic, approximated by interfaced Lambertian microfacets (" +
                         dist + " + Smith, ni = int_ior / ext_ior, Kd = diffuse_reflectance)");
        mp.out().notes.push_back("approximation: Mitsuba adds a specular microfacet lobe to a "
                                 "diffuse base attenuated by the rough interface's "
                                 "transmission; this model makes every facet an interface "
                                 "over a Lambertian substrate");
        mp.set("alpha", alpha);
        mp.set("ni", ni);
        mp.out().options = {{"distribution", dist + "-smith"}, {"sampling", "visible"}};
        mp.out().factored = {{"kd", r.factor("diffuse_reflectance", 0.5)}};
        if (r.flag("nonlinear", false))
            mp.out().notes.push_back("nonlinear = true (Mitsuba's internal-scattering colour "
                                     "shift) is not part of the interfaced-Lambertian model");
        return mp.result();
    }
    if (t == "roughdiffuse") {
        // Mitsuba 0.6: alpha is the RMS slope of the facets; the Oren-Nayar
        // sigma (standard deviation of the slope angle, radians) is alpha/sqrt(2).
        const Value alpha = r.number("alpha", 0.2);
        const Value sigma =
            alpha.map([](double a) { return a / std::sqrt(2.0) * 180.0 / 3.14159265358979323846; });
        if (!sigma.ranged && sigma.value == 0) return mp.no_table("alpha = 0: Lambertian");
        mp.tabulated("oren-nayar",
                     "Mitsuba 0.6 roughdiffuse: the exact V-cavity Oren-Nayar model with "
                     "sigma = alpha / sqrt(2) radians, rho = reflectance factored out");
        mp.set("sigma", sigma);
        mp.out().factored = {{"rho", r.factor("reflectance", 0.5)}};
        if (r.flag("use_fast_approx", false))
            mp.out().notes.push_back("useFastApprox selects Mitsuba's single-bounce "
                                     "approximation; the table holds the full model");
        return mp.result();
    }
    if (t == "diffuse") return mp.no_table("Lambertian: a closed form");
    if (t == "dielectric" || t == "thindielectric")
        return mp.no_table("smooth dielectric: closed-form Fresnel reflection and refraction");
    if (t == "null") return mp.no_table("passes light through unchanged");
    if (t == "conductor" || t == "roughconductor")
        return mp.unsupported("brdftab has no conductor model (a rough conductor's single "
                              "scattering is a closed form in the renderer)");
    if (t == "blendbsdf")
        return mp.unsupported("a blend of two BSDFs; its parts are listed on their own");
    if (t == "measured" || t == "measured_polarized")
        return mp.unsupported("measured data is a table already");
    return mp.unsupported("no brdftab model for Mitsuba BSDF type '" + t + "'");
}

MappedMaterial map_native(const SceneMaterial& m) {
    Mapper mp(m);
    const ModelInfo* model = nullptr;
    try {
        model = &find_model(m.native_model);
    } catch (const InputError& e) {
        throw InputError(mp.r().label() + ": " + e.what());
    }
    if (model->name == "hfunction")
        return mp.unsupported("hfunction is a function of radiative transfer, not a material");
    mp.tabulated(model->name, "brdftab material list: " + model->name + " with the given values");
    for (const auto& [name, p] : m.parameters) {
        if (const ParameterInfo* info = model->find_parameter(name)) {
            (void)info;
            Value v = mp.r().number(name, 0);
            if (model->name == "oren-nayar" && name == "rho") {
                mp.out().factored["rho"] = v.value;
                continue;
            }
            if (model->name == "interfaced-lambertian" && name == "kd") {
                mp.out().factored["kd"] = v.value;
                continue;
            }
            mp.set(name, v);
        } else if (const OptionInfo* opt = model->find_option(name)) {
            const std::string choice = mp.r().text(name, "");
            if (std::find(opt->choices.begin(), opt->choices.end(), choice) == opt->choices.end()) {
                std::string all;
                for (const auto& c : opt->choices) all += (all.empty() ? "" : ", ") + c;
                throw InputError(p.where + ": " + mp.r().label() + ": option " + name + " = '" +
                                 choice + "' is not one of " + all);
            }
            mp.out().options[name] = choice;
        } else {
            throw InputError(p.where + ": " + mp.r().label() + ": '" + name +
                             "' is neither a parameter nor an option of " + model->name +
                             " (see `brdftab models " + model->name + "`)");
        }
    }
    return mp.result();
}

// The parts of a tabulated material's BSDF that are closed forms (scene.h,
// MappedMaterial::closed_forms), whichever renderer it came from.
void mark_closed_forms(MappedMaterial& m) {
    if (m.status != MaterialStatus::Tabulated) return;
    if (m.model == "rough-dielectric")
        m.closed_forms["bsdf"] =
            "the BSDF is a closed form (Walter et al. 2007: f_r and f_t, eqs. 20-21, with the "
            "mapped D and G) that the renderer evaluates itself: no BSDF table; only its albedos "
            "(energy compensation, --for albedo or all) are tabulated";
    else if (m.model == "interfaced-lambertian")
        m.closed_forms["specular"] =
            "the coating's specular reflection is a closed form (the microfacet f_r of its "
            "interface) that the renderer evaluates itself; the BSDF table holds only the body "
            "(light through the interface and back)";
}

}  // namespace

MappedMaterial map_material(const SceneMaterial& material) {
    if (!material.used) {
        MappedMaterial out;
        out.source = material;
        out.status = MaterialStatus::NoTableNeeded;
        out.reason = "defined, but no shape uses it";
        return out;
    }
    MappedMaterial out = material.format == "brdftab"                 ? map_native(material)
                         : material.format.rfind("mitsuba", 0) == 0 ? map_mitsuba(material)
                                                                      : map_pbrt(material);
    mark_closed_forms(out);
    return out;
}

}  // namespace brdftab
