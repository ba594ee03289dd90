// scene.h — from a renderer's scene file to the smallest set of brdftab tables
// that its materials need (`brdftab scene`, docs/scenes.md).
//
// Three steps, each a library function (the CLI only prints):
//   1. read_scene_materials(): the scene's materials as the renderer wrote
//      them (pbrt-v3/v4 text, Mitsuba 0.6/3 XML, or brdftab's own TOML list),
//      with their parameters untouched and where each was defined;
//   2. map_material(): one material -> a brdftab model and its parameters in
//      brdftab's conventions, or the reason it needs no table / is not
//      supported;
//   3. plan_scene_tables(): materials that share a model and parameters share
//      one table set (factored parameters such as Oren-Nayar's rho or the
//      interfaced-Lambertian Kd never split a table); each set becomes an
//      ordinary spec, generated and written like `brdftab generate` does.
//
// Errors are InputError: syntax errors name file:line:column (pbrt, TOML) or
// the XML element path (Mitsuba); a parameter outside the model's range names
// the material.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace brdftab {

// One parameter as the scene wrote it.
struct SceneParameter {
    std::string type;                // pbrt: "float", "string", "texture", ...; XML: element name
    std::vector<double> numbers;     // numeric values (float, integer, rgb, spectrum as numbers)
    std::vector<std::string> texts;  // string / texture-name / bool values
    std::string where;               // file:line:col or XML element path
    // Set when the value comes from an image texture: the file (resolved
    // against the scene's directory) and the channel statistics.
    std::optional<std::string> image;
    bool image_missing = false;
    double image_min = 0, image_max = 0;
};

struct SceneMaterial {
    std::string name;    // the scene's name, or a generated one ("anonymous-3")
    bool anonymous = false;
    std::string format;  // "pbrt-v3", "pbrt-v4", "pbrt", "mitsuba", "mitsuba-0.6", "brdftab"
    std::string type;    // the renderer's material type ("coateddiffuse", "roughdielectric")
    std::string where;   // where it was defined
    bool used = true;    // false: defined but no shape refers to it
    std::map<std::string, SceneParameter> parameters;
    // brdftab-native lists name the model directly.
    std::string native_model;
    std::string wrapped_in;  // e.g. "twosided" for a Mitsuba BSDF inside a wrapper
};

// Reads every material of a scene file.  The format comes from the file
// (extension .pbrt -> pbrt, .xml -> Mitsuba, .toml -> brdftab list) unless
// `format` names one: "pbrt", "mitsuba", "toml".  Includes and imports are
// followed relative to the including file.
std::vector<SceneMaterial> read_scene_materials(const std::string& path,
                                                const std::string& format = "");

// The Mitsuba named indices of refraction (case-insensitive); nullopt for an
// unknown name.
std::optional<double> mitsuba_named_ior(const std::string& name);

// pbrt's roughness -> alpha remappings.
double pbrt_v4_roughness_to_alpha(double roughness);  // sqrt(roughness)
double pbrt_v3_roughness_to_alpha(double roughness);  // pbrt-v3's quartic in log(roughness)

enum class MaterialStatus { Tabulated, NoTableNeeded, Unsupported };
const char* to_string(MaterialStatus status);

// A material in brdftab's terms.
struct MappedMaterial {
    SceneMaterial source;
    MaterialStatus status = MaterialStatus::Unsupported;
    std::string reason;  // why no table, why unsupported, or how it maps
    std::string model;   // brdftab model name
    std::map<std::string, double> parameters;  // brdftab parameters, brdftab units
    // Parameters driven by textures: the range of values they take.
    std::map<std::string, std::pair<double, double>> parameter_ranges;
    std::map<std::string, std::string> options;  // categorical options
    nlohmann::json factored = nlohmann::json::object();  // e.g. {"kd": 0.64}
    std::vector<std::string> notes;  // approximations and assumptions, in words
    // Parts of the material's BSDF that are closed forms a renderer evaluates
    // itself, so they get no table: part -> why.  "bsdf": the whole BSDF
    // (rough dielectric f_r/f_t: only its albedos are tabulated); "specular":
    // the interfaced-Lambertian coating's specular reflection (only the body
    // is tabulated).  Under --tabulate-closed-forms a "bsdf" part is
    // tabulated all the same and left out of this map.
    std::map<std::string, std::string> closed_forms;
};

// Maps one material.  Throws InputError naming the material when a value is
// outside the model's range (e.g. eta = 0).
MappedMaterial map_material(const SceneMaterial& material);

enum class ScenePurpose { Bsdf, Albedo, All };
ScenePurpose parse_scene_purpose(const std::string& text);  // "bsdf" | "albedo" | "all"

// One table set: an ordinary spec (TOML text, parsed by the normal spec
// parser) shared by the materials listed.
struct SceneTableSet {
    std::string id;          // prefix of its table names in the output file ("t0")
    std::string model;
    std::string purpose;     // "bsdf" | "albedo"
    std::string spec_text;   // the spec
    std::string main_table;  // the table a renderer binds a material to
    std::vector<std::string> tables;    // every table name it writes
    std::vector<std::string> materials; // names of the materials it serves
    // Other tables a renderer binds, by role (manifest `tables`): e.g.
    // "bsdf_transmission" for the rough-dielectric BSDF's transmission table.
    std::map<std::string, std::string> roles;
    // Set by plan_table_set(): whether the planner chose the node counts and
    // samples (else the template's are kept, and plan_note says why), and
    // its predictions for the whole set.
    bool planned = false;
    double predicted_error = 0, predicted_seconds = 0;
    std::map<std::string, double> table_predicted_error;  // per planned table (and recombined table)
    // The planner's cost model for this set: engine seconds per cell at the
    // planned samples (startup and per-run overhead excluded) and those
    // fixed seconds; used to predict what the presets would cost.
    double seconds_per_cell = 0, fixed_seconds = 0;
    // Set by certify_table_set(): each table's measured total error
    // (host/plan/certify.h), in the set's measure.
    struct TableCertificate {
        std::string table;
        double max_error = 0, rms_error = 0;  // rms: 0 for recombined tables (a bound)
        double target = 0;
        double floor = 0;  // relative errors divide by max(|value|, floor) (table units)
        bool passed = false;
        // "measured" (off-grid probes against the model), or for a recombined
        // table "bound from the terms' certificates" (at the worst rho).
        std::string how;
        std::map<std::string, double> max_at;  // coordinates of the max (measured only)
    };
    std::vector<TableCertificate> certificates;
    std::string plan_note;
};

struct ScenePlanSettings {
    ScenePurpose purpose = ScenePurpose::All;
    double accuracy = 1e-3;  // integration tolerance of the estimated tables
    std::uint64_t seed = 1;
    // BSDF tables for materials whose BSDF is a closed form (rough
    // dielectrics) too; by default they get none (MappedMaterial::closed_forms).
    bool tabulate_closed_forms = false;
};

struct ScenePlan {
    std::vector<MappedMaterial> materials;
    std::vector<SceneTableSet> sets;
};

ScenePlan plan_scene_tables(const std::vector<SceneMaterial>& materials,
                            const ScenePlanSettings& settings);

// Replaces a set's template resolution by the speed/accuracy planner's choice
// (host/plan): short pilots on `backend`, then the fastest plan predicted to
// reach `accuracy` (max total relative error, linear interpolation), or with
// `budget_seconds` > 0 the most accurate plan predicted to finish in that
// time.  Recombined tables (Oren-Nayar's rho) are planned with their terms
// on one node layout.  A closed-form set no joint plan reaches is planned
// table by table, a table no plan reaches keeping its template counts; when
// nothing can be planned the template stays.  set.plan_note says what was
// kept and why.  `progress` receives the pilot's progress.
class Backend;
struct Progress;
void plan_table_set(SceneTableSet& set, Backend& backend, double accuracy, double budget_seconds,
                    const std::function<void(const std::string&, const Progress&)>& progress);

// Certifies every table of a generated set in `file` (host/plan/certify.h:
// the stored values, interpolated linearly as a renderer does, against the
// mapped model at off-grid probes), stores each certificate in the file and
// in set.certificates.  `target` is the set's accuracy (max total error;
// relative with the floor 1e-3 x max for BSDF sets, absolute for albedo
// sets).  Recombined tables have no model quantity of their own to probe:
// their certificate is the bound of plan.h's predict_recombined applied to
// the terms' certificates.
void certify_table_set(SceneTableSet& set, const std::string& file, Backend& backend, double target,
                       const std::function<void(const std::string&, const Progress&)>& progress);

// The manifest (docs/scenes.md): per material name, type, status, reason,
// model, parameters, table, factored, notes.
nlohmann::json scene_manifest(const ScenePlan& plan, const std::string& scene_file,
                              const std::string& table_file);

}  // namespace brdftab
