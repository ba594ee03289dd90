// scene_plan.cpp — materials -> the fewest table sets, each an ordinary spec.
//
// Materials share a table set when they map to the same model, options and
// (non-factored) parameters: Oren-Nayar's rho and the interfaced-Lambertian
// Kd are factored out of the tables, which is why those factorizations exist.
// A parameter driven by a texture becomes an axis over the texture's range.
//
// The angular axes and sample budgets start from the templates below (the
// presets' resolutions with the parameter axes removed); plan_table_set()
// (scene_planning.cpp) replaces them by the planner's choice where it can,
// and `--accuracy` is the integration tolerance of the sets it cannot plan.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "host/core/error.h"
#include "host/models/registry.h"
#include "host/scene/scene.h"
#include "host/scene/scene_internal.h"

namespace brdftab {

namespace {

bool ends_with(const std::string& s, const std::string& suffix) {
    return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string num(double v) {
    std::ostringstream s;
    s.precision(17);
    s << v;
    std::string out = s.str();
    // TOML floats need a '.' or an exponent.
    if (out.find_first_of(".eEn") == std::string::npos) out += ".0";
    return out;
}

struct AxisTemplate {
    const char* name;
    double lo, hi;
    int count;
};

struct TableTemplate {
    const char* suffix;    // table name after the set prefix
    const char* quantity;
    std::vector<std::pair<const char*, const char*>> options;  // extra per-table options
    std::vector<AxisTemplate> axes;  // angular axes; parameter axes are appended
};

struct SetTemplate {
    std::vector<TableTemplate> tables;
    std::string main;             // table a material binds to
    std::string recombined;       // TOML of [[recombined]] blocks (with {P} for the prefix)
    std::string integration;      // TOML [integration] body (with {TOL} and {FLOOR})
    std::map<std::string, std::string> fixed_parameters;  // extra fixed parameters (TOML values)
    std::map<std::string, std::string> roles;  // manifest role -> table suffix, besides the main one
};

const AxisTemplate kThetaI85{"theta_i", 0, 85, 18}, kThetaO85{"theta_o", 0, 85, 18};

// `anisotropic`: interfaced-lambertian with alpha_x / alpha_y (pbrt-v4
// uroughness != vroughness): its tables need both azimuths.
SetTemplate set_template(const std::string& model, const std::string& purpose, bool anisotropic) {
    SetTemplate t;
    const std::string estimated =
        "method = \"rqmc\"\nsamples = 1024\ntolerance = {TOL}\nabs_floor = {FLOOR}\n"
        "max_samples = 1048576\nseed = {SEED}\n";
    if (model == "rough-dielectric") {
        if (purpose == "bsdf") {
            // Closed form: 2-degree steps cost nothing.  Reflection and
            // transmission in two tables, each away from the horizon: in one
            // `bsdf` table over theta_o 0-180 the jump between f_r and f_t at
            // theta_o = 90 kept the relative interpolation error near 1 at any
            // node count, and the node theta_i = theta_o = 90 held the
            // grazing forward-scattering divergence of f_r (~1/cos theta under
            // Smith masking: 2.5e9 1/sr at alpha = 0.32), which set the
            // relative floor (1e-3 of the largest value) to 2.5e6 1/sr.
            const AxisTemplate ti{"theta_i", 0, 88, 45}, pd{"phi_d", 0, 180, 37};
            t.tables = {{"bsdf_reflection", "brdf", {}, {ti, {"theta_o", 0, 88, 45}, pd}},
                        {"bsdf_transmission", "btdf", {}, {ti, {"theta_o", 92, 180, 45}, pd}}};
            t.main = "bsdf_reflection";
            t.roles = {{"bsdf_transmission", "bsdf_transmission"}};
            return t;
        }
        t.tables = {
            {"albedo_r", "albedo_r", {}, {{"mu_i", 0.02, 1.0, 50}}},
            {"albedo_t", "albedo_t", {}, {{"mu_i", 0.02, 1.0, 50}}},
            {"albedo_r_inside", "albedo_r", {}, {{"mu_i", -1.0, -0.02, 50}}},
            {"albedo_t_inside", "albedo_t", {}, {{"mu_i", -1.0, -0.02, 50}}},
            {"albedo_avg", "albedo_avg", {{"lobe", "both"}, {"side", "outside"}}, {}},
            {"albedo_avg_inside", "albedo_avg", {{"lobe", "both"}, {"side", "inside"}}, {}}};
        t.main = "albedo_r";
        t.integration = estimated;
        return t;
    }
    if (model == "interfaced-lambertian" && anisotropic) {
        // As tables/interfaced-lambertian-anisotropic.toml: the axis-aligned
        // anisotropic D is even in x and in y, so phi_i in [0, 90] covers
        // every incidence azimuth; phi_o over the full circle, from the x axis.
        const AxisTemplate phi_i{"phi_i", 0, 90, 7};
        if (purpose == "bsdf") {
            t.tables = {{"body", "body", {}, {kThetaI85, phi_i, kThetaO85, {"phi_o", 0, 360, 25}}}};
            t.main = "body";
        } else {
            t.tables = {{"albedo_body", "albedo_body", {}, {{"theta_i", 0, 89, 30}, phi_i}},
                        {"albedo_specular", "albedo_specular", {}, {{"theta_i", 0, 89, 30}, phi_i}}};
            t.fixed_parameters["kd"] = "1.0";
            t.main = "albedo_body";
        }
        t.integration = estimated;
        return t;
    }
    if (model == "interfaced-lambertian") {
        if (purpose == "bsdf") {
            t.tables = {{"body", "body", {}, {kThetaI85, kThetaO85, {"phi_d", 0, 180, 10}}}};
            t.main = "body";
        } else {
            // albedo_body carries Kd/(pi ni^2 (1 - ri Kd)); at Kd = 1 a renderer
            // rescales it by Kd (1 - ri) / (1 - ri Kd) (docs/scenes.md).
            t.tables = {{"albedo_body", "albedo_body", {}, {{"theta_i", 0, 89, 30}}},
                        {"albedo_specular", "albedo_specular", {}, {{"theta_i", 0, 89, 30}}}};
            t.fixed_parameters["kd"] = "1.0";
            t.main = "albedo_body";
        }
        t.integration = estimated;
        return t;
    }
    if (model == "oren-nayar") {
        if (purpose == "bsdf") {
            const std::vector<AxisTemplate> axes = {
                {"theta_i", 0, 88, 23}, {"theta_o", 0, 88, 23}, {"phi_d", 0, 180, 19}};
            t.tables = {{"brdf_direct", "brdf_direct", {}, axes},
                        {"brdf_interreflection", "brdf_interreflection", {}, axes}};
            t.recombined =
                "[[recombined]]\nname = \"{P}brdf\"\nparameter = \"rho\"\nrange = [0.0, 1.0]\n"
                "[[recombined.terms]]\ntable = \"{P}brdf_direct\"\ncoeffs = [0.0, 1.0]\n"
                "[[recombined.terms]]\ntable = \"{P}brdf_interreflection\"\n"
                "coeffs = [0.0, 0.0, 1.0]\n";
            t.main = "brdf";
            t.integration = "method = \"quadrature\"\n";
            t.fixed_parameters["nodes"] = "12";
        } else {
            const std::vector<AxisTemplate> axes = {{"mu_i", 0.02, 1.0, 32}};
            t.tables = {{"albedo_direct", "albedo_direct", {}, axes},
                        {"albedo_interreflection", "albedo_interreflection", {}, axes}};
            t.recombined =
                "[[recombined]]\nname = \"{P}albedo\"\nparameter = \"rho\"\nrange = [0.0, 1.0]\n"
                "[[recombined.terms]]\ntable = \"{P}albedo_direct\"\ncoeffs = [0.0, 1.0]\n"
                "[[recombined.terms]]\ntable = \"{P}albedo_interreflection\"\n"
                "coeffs = [0.0, 0.0, 1.0]\n";
            t.main = "albedo";
            t.integration = estimated;
        }
        return t;
    }
    if (model == "lambert-sphere") {
        if (purpose == "bsdf") {
            t.tables = {{"brdf_mc", "brdf_mc", {}, {{"theta_i", 0, 85, 10}, {"theta_o", 0, 85, 10},
                                                    {"phi_d", 0, 180, 7}}}};
            t.main = "brdf_mc";
        } else {
            t.tables = {{"albedo_mc", "albedo_mc", {}, {{"mu_i", 0.02, 1.0, 32}}}};
            t.main = "albedo_mc";
        }
        t.integration =
            "method = \"mc\"\nsamples = 4096\ntolerance = {TOL}\nabs_floor = {FLOOR}\n"
            "max_samples = 1048576\nseed = {SEED}\n";
        return t;
    }
    if (model == "micrograin") {
        if (purpose == "bsdf") {
            t.tables = {{"brdf", "brdf", {}, {{"theta_i", 0, 87, 16}, {"theta_o", 0, 87, 16},
                                              {"phi_d", 0, 180, 13}}}};
            t.main = "brdf";
        } else {
            t.tables = {{"albedo", "albedo", {}, {{"theta_i", 0, 89, 30}}}};
            t.main = "albedo";
        }
        t.integration = estimated;
        return t;
    }
    throw std::logic_error("scene: no table template for model " + model);
}

void replace_all(std::string& s, const std::string& what, const std::string& with) {
    for (std::size_t p = s.find(what); p != std::string::npos; p = s.find(what, p + with.size()))
        s.replace(p, what.size(), with);
}

// The key under which materials share a table set.
std::string share_key(const MappedMaterial& m, const std::string& purpose) {
    std::ostringstream k;
    k << m.model << '|' << purpose;
    for (const auto& [n, v] : m.parameters) k << '|' << n << '=' << num(v);
    for (const auto& [n, r] : m.parameter_ranges)
        k << '|' << n << "=[" << num(r.first) << ',' << num(r.second) << ']';
    for (const auto& [n, v] : m.options) k << '|' << n << '=' << v;
    return k.str();
}

std::string spec_text(const SceneTableSet& set, const MappedMaterial& m, const SetTemplate& t,
                      const ScenePlanSettings& settings, std::vector<std::string>& tables) {
    std::ostringstream s;
    s << "# Table set " << set.id << " of `brdftab scene` (" << set.purpose << ") for: ";
    for (std::size_t k = 0; k < set.materials.size(); ++k)
        s << (k ? ", " : "") << set.materials[k];
    s << "\nmodel = \"" << m.model << "\"\n";
    s << "description = \"" << m.model << " " << set.purpose << " tables for scene materials\"\n";
    s << "\n[parameters]\n";
    for (const auto& [n, v] : m.parameters) s << n << " = " << num(v) << "\n";
    for (const auto& [n, v] : t.fixed_parameters)
        if (!m.parameters.count(n)) s << n << " = " << v << "\n";
    for (const auto& [n, v] : m.options) s << n << " = \"" << v << "\"\n";
    for (const TableTemplate& tt : t.tables) {
        // Without texture-driven axes a table with no angular axis (the
        // average albedo at fixed parameters) would hold one number: it is
        // left out, and the directional tables carry the information.
        if (tt.axes.empty() && m.parameter_ranges.empty()) continue;
        const std::string name = set.id + "_" + tt.suffix;
        tables.push_back(name);
        s << "\n[[tables]]\nname = \"" << name << "\"\nquantity = \"" << tt.quantity << "\"\n";
        if (!tt.options.empty()) {
            s << "[tables.parameters]\n";
            for (const auto& [n, v] : tt.options) s << n << " = \"" << v << "\"\n";
        }
        for (const AxisTemplate& a : tt.axes)
            s << "[[tables.axes]]\nname = \"" << a.name << "\"\nrange = [" << num(a.lo) << ", "
              << num(a.hi) << "]\ncount = " << a.count << "\n";
        for (const auto& [n, r] : m.parameter_ranges) {
            s << "[[tables.axes]]\nname = \"" << n << "\"\nrange = [" << num(r.first) << ", "
              << num(r.second) << "]\ncount = 8\n";
            if (r.first > 0 && r.second / r.first > 4) s << "spacing = \"log\"\n";
        }
    }
    if (!t.recombined.empty()) {
        std::string rec = t.recombined;
        replace_all(rec, "{P}", set.id + "_");
        s << "\n" << rec;
        tables.push_back(set.id + "_" + t.main);
    }
    if (!t.integration.empty()) {
        std::string integ = t.integration;
        replace_all(integ, "{TOL}", num(settings.accuracy));
        replace_all(integ, "{FLOOR}", num(settings.accuracy * 0.1));
        replace_all(integ, "{SEED}", std::to_string(settings.seed));
        s << "\n[integration]\n" << integ;
    }
    s << "\n[output]\ntype = \"float32\"\ncompression = 6\nkeep_stderr = true\n";
    return s.str();
}

}  // namespace

namespace scene_detail {
std::string read_scene_text(const std::string& path, int depth, const char* include_directive) {
    if (depth > 32)
        throw InputError(path + ": " + include_directive +
                         " nested more than 32 deep (an include cycle?)");
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError("cannot read scene file '" + path + "'");
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}
}  // namespace scene_detail

std::vector<SceneMaterial> read_scene_materials(const std::string& path, const std::string& format) {
    std::string f = format;
    if (f.empty()) {
        if (ends_with(path, ".pbrt")) f = "pbrt";
        else if (ends_with(path, ".xml")) f = "mitsuba";
        else if (ends_with(path, ".toml")) f = "toml";
        else
            throw InputError("scene file '" + path +
                             "': cannot tell its format from the extension (.pbrt, .xml, .toml); "
                             "name it with --format pbrt|mitsuba|toml");
    }
    if (f == "pbrt") return scene_detail::read_pbrt_scene(path);
    if (f == "mitsuba") return scene_detail::read_mitsuba_scene(path);
    if (f == "toml") return scene_detail::read_native_materials(path);
    throw InputError("--format '" + f + "': allowed: pbrt, mitsuba, toml");
}

ScenePurpose parse_scene_purpose(const std::string& text) {
    if (text == "bsdf") return ScenePurpose::Bsdf;
    if (text == "albedo") return ScenePurpose::Albedo;
    if (text == "all") return ScenePurpose::All;
    throw InputError("--for '" + text + "': allowed: bsdf, albedo, all");
}

ScenePlan plan_scene_tables(const std::vector<SceneMaterial>& materials,
                            const ScenePlanSettings& settings) {
    if (!(settings.accuracy > 0 && settings.accuracy < 1))
        throw InputError("--accuracy " + num(settings.accuracy) + ": allowed range (0, 1)");
    ScenePlan plan;
    for (const SceneMaterial& m : materials) plan.materials.push_back(map_material(m));
    if (settings.tabulate_closed_forms)
        for (MappedMaterial& m : plan.materials)
            if (m.closed_forms.erase("bsdf"))
                m.notes.push_back("the BSDF is a closed form, tabulated because of "
                                  "--tabulate-closed-forms");
    std::vector<std::string> purposes;
    if (settings.purpose != ScenePurpose::Albedo) purposes.push_back("bsdf");
    if (settings.purpose != ScenePurpose::Bsdf) purposes.push_back("albedo");
    std::map<std::string, std::size_t> by_key;
    for (const std::string& purpose : purposes) {
        for (const MappedMaterial& m : plan.materials) {
            if (m.status != MaterialStatus::Tabulated) continue;
            if (purpose == "bsdf" && m.closed_forms.count("bsdf")) continue;
            const std::string key = share_key(m, purpose);
            auto it = by_key.find(key);
            if (it != by_key.end()) {
                plan.sets[it->second].materials.push_back(m.source.name);
                continue;
            }
            SceneTableSet set;
            set.id = "t" + std::to_string(plan.sets.size());
            set.model = m.model;
            set.purpose = purpose;
            set.materials.push_back(m.source.name);
            by_key[key] = plan.sets.size();
            plan.sets.push_back(set);
        }
    }
    // A material whose only tables were its closed-form BSDF's (--for bsdf)
    // needs none: it says why, and how it maps becomes a note.
    for (MappedMaterial& m : plan.materials) {
        if (m.status != MaterialStatus::Tabulated || !m.closed_forms.count("bsdf")) continue;
        const bool served = std::any_of(plan.sets.begin(), plan.sets.end(), [&](const SceneTableSet& set) {
            return std::find(set.materials.begin(), set.materials.end(), m.source.name) != set.materials.end();
        });
        if (served) continue;
        m.notes.insert(m.notes.begin(), "maps to " + m.model + ": " + m.reason);
        m.status = MaterialStatus::NoTableNeeded;
        m.reason = m.closed_forms.at("bsdf");
    }
    // Spec texts once the material lists are complete (they are named in a comment).
    for (SceneTableSet& set : plan.sets) {
        const MappedMaterial* first = nullptr;
        for (const MappedMaterial& m : plan.materials)
            if (m.source.name == set.materials.front() && m.status == MaterialStatus::Tabulated)
                first = &m;
        auto positive = [&](const char* n) {
            auto it = first->parameters.find(n);
            return it != first->parameters.end() && it->second > 0;
        };
        const SetTemplate t =
            set_template(set.model, set.purpose, positive("alpha_x") || positive("alpha_y"));
        set.spec_text = spec_text(set, *first, t, settings, set.tables);
        set.main_table = set.id + "_" + t.main;
        for (const auto& [role, suffix] : t.roles) set.roles[role] = set.id + "_" + suffix;
    }
    return plan;
}

nlohmann::json scene_manifest(const ScenePlan& plan, const std::string& scene_file,
                              const std::string& table_file) {
    nlohmann::json out;
    out["scene"] = scene_file;
    out["tables_file"] = table_file;
    out["materials"] = nlohmann::json::array();
    for (const MappedMaterial& m : plan.materials) {
        nlohmann::json j;
        j["name"] = m.source.name;
        j["type"] = m.source.type;
        j["format"] = m.source.format;
        j["defined_at"] = m.source.where;
        j["status"] = to_string(m.status);
        j["reason"] = m.reason;
        j["model"] = m.model.empty() ? nlohmann::json() : nlohmann::json(m.model);
        nlohmann::json params = nlohmann::json::object();
        for (const auto& [n, v] : m.parameters) params[n] = v;
        for (const auto& [n, r] : m.parameter_ranges) params[n] = {{"range", {r.first, r.second}}};
        for (const auto& [n, v] : m.options) params[n] = v;
        j["parameters"] = params;
        nlohmann::json tables = nlohmann::json::object();
        for (const SceneTableSet& set : plan.sets)
            if (std::find(set.materials.begin(), set.materials.end(), m.source.name) !=
                set.materials.end()) {
                tables[set.purpose] = set.main_table;
                for (const auto& [role, name] : set.roles) tables[role] = name;
            }
        // `table`: the BSDF table when there is one, else the albedo table.
        if (tables.contains("bsdf")) j["table"] = tables["bsdf"];
        else if (tables.contains("albedo")) j["table"] = tables["albedo"];
        else j["table"] = nullptr;
        j["tables"] = tables;
        // Certified: the worst of the sets serving the material.
        bool certified = false, passed = true;
        double worst = 0;
        for (const SceneTableSet& set : plan.sets)
            if (!set.certificates.empty() &&
                std::find(set.materials.begin(), set.materials.end(), m.source.name) != set.materials.end())
                for (const SceneTableSet::TableCertificate& c : set.certificates) {
                    certified = true;
                    worst = std::max(worst, c.max_error);
                    passed = passed && c.passed;
                }
        if (certified) j["certified_error"] = worst, j["passed"] = passed;
        j["factored"] = m.factored;
        if (!m.closed_forms.empty()) {
            nlohmann::json parts = nlohmann::json::object();
            for (const auto& [part, why] : m.closed_forms) parts[part] = {{"status", "no-table-needed"}, {"reason", why}};
            j["closed_forms"] = parts;
        }
        j["notes"] = m.notes;
        if (!m.source.wrapped_in.empty()) j["wrapped_in"] = m.source.wrapped_in;
        out["materials"].push_back(j);
    }
    out["table_sets"] = nlohmann::json::array();
    for (const SceneTableSet& set : plan.sets)
    {
        nlohmann::json j = {{"id", set.id},
                            {"model", set.model},
                            {"purpose", set.purpose},
                            {"tables", set.tables},
                            {"main_table", set.main_table},
                            {"materials", set.materials},
                            {"planned", set.planned}};
        if (set.planned) {
            j["predicted_error"] = set.predicted_error;
            j["predicted_seconds"] = set.predicted_seconds;
            if (!set.table_predicted_error.empty()) j["table_predicted_error"] = set.table_predicted_error;
        }
        if (!set.plan_note.empty()) j["plan_note"] = set.plan_note;
        if (!set.certificates.empty()) {
            double worst = 0;
            bool passed = true;
            nlohmann::json per = nlohmann::json::object();
            for (const SceneTableSet::TableCertificate& c : set.certificates) {
                worst = std::max(worst, c.max_error);
                passed = passed && c.passed;
                nlohmann::json t = {{"certified_error", c.max_error}, {"passed", c.passed},
                                    {"target", c.target}, {"how", c.how}};
                if (c.how == "measured")
                    t["rms_error"] = c.rms_error, t["max_at"] = c.max_at, t["floor"] = c.floor;
                per[c.table] = t;
            }
            j["certified_error"] = worst;
            j["passed"] = passed;
            j["measure"] = set.purpose == "albedo" ? "absolute" : "relative (floor 1e-3 x max |value|)";
            j["certificates"] = per;
        }
        out["table_sets"].push_back(j);
    }
    return out;
}

}  // namespace brdftab
