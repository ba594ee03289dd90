// scene: the tables a scene's materials need, and a manifest binding each
// material to its table (host/scene/scene.h, docs/scenes.md).

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <iomanip>
#include <set>
#include <iostream>
#include <sstream>

#include "host/cli/cli_common.h"
#include "host/cli/commands.h"
#include "host/core/atomic_file.h"
#include "host/core/error.h"
#include "host/generate/chunked.h"
#include "host/generate/generate.h"
#include "host/io/table_io.h"
#include "host/plan/adaptive_plan.h"
#include "host/scene/scene.h"
#include "host/spec/spec.h"

namespace brdftab::cli {

namespace {

std::string cells_text(double cells) {
    std::ostringstream s;
    s << static_cast<unsigned long long>(cells) << " cells";
    return s.str();
}

// Presets of the same model and purpose, for the "what it saved" line.
std::string preset_for(const std::string& model, const std::string& purpose) {
    if (model == "rough-dielectric") return purpose == "bsdf" ? "rough-dielectric-bsdf" : "rough-dielectric-albedo";
    if (model == "oren-nayar") return purpose == "bsdf" ? "oren-nayar-brdf" : "oren-nayar-albedo";
    if (model == "interfaced-lambertian") return purpose == "bsdf" ? "interfaced-lambertian-body" : "";
    if (model == "lambert-sphere") return purpose == "bsdf" ? "lambert-sphere-brdf" : "lambert-sphere-albedo";
    if (model == "micrograin") return purpose == "bsdf" ? "micrograin-brdf-diffuse" : "";
    return "";
}

std::string find_presets_dir(const std::string& given) {
    namespace fs = std::filesystem;
    if (!given.empty()) return given;
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) {
        for (const fs::path& p : {exe.parent_path() / "../share/brdftab/tables",
                                  exe.parent_path() / "../tables"})
            if (fs::is_directory(p, ec)) return p.lexically_normal().string();
    }
    return "";
}

std::string seconds_text(double s) {
    std::ostringstream o;
    o.precision(3);
    o << s << " s";
    return o.str();
}

// The pre-check of `generate` for the whole scene, before anything is
// computed (InputError, exit 2).  The sets are generated one after the
// other into one file, each streamed in chunks (generate_into): memory is
// the largest set's estimate, disk the sum.
void check_scene_resources(const std::vector<Spec>& specs, const std::vector<IntegrationSettings>& settings,
                           const std::string& out_path, std::uint64_t max_memory) {
    double memory = 0, disk = 0, cells = 0;
    for (std::size_t k = 0; k < specs.size(); ++k) {
        const ResourceEstimate e = estimate_resources(specs[k], settings[k]);
        memory = std::max(memory, e.memory_bytes);
        disk += e.disk_bytes;
        cells += e.cells;
    }
    const std::string what = "the scene's tables (" + format_count(cells) + " cells)";
    if (max_memory && memory > static_cast<double>(max_memory))
        throw InputError(what + " need about " + format_bytes(memory) + " of memory, above --max-memory " +
                         format_bytes(static_cast<double>(max_memory)) +
                         "; ask for less (--accuracy larger, or --budget), or --for bsdf / albedo alone");
    const double available = max_memory ? 0 : available_memory();
    if (available > 0 && memory > available)
        throw InputError(what + " need about " + format_bytes(memory) + " of memory, but only " +
                         format_bytes(available) + " is available (MemAvailable); ask for less "
                         "(--accuracy larger, or --budget), or give --max-memory");
    const double free_space = free_disk_space(out_path);
    if (free_space >= 0 && disk > free_space)
        throw InputError(out_path + ": " + what + " need about " + format_bytes(disk) +
                         " on disk before compression, but only " + format_bytes(free_space) +
                         " is free on its file system; write elsewhere (-o) or ask for less");
}

// What was found in the scene, and what each material becomes (with the
// parts of a tabulated material that stay closed forms).
void print_materials(const std::string& scene, const std::vector<MappedMaterial>& materials) {
    std::cout << "scene " << scene << ": " << materials.size() << " material(s)\n";
    for (const MappedMaterial& m : materials) {
        std::cout << "  " << std::left << std::setw(22) << m.source.name << " "
                  << std::setw(18) << m.source.type << " " << to_string(m.status);
        if (m.status == MaterialStatus::Tabulated) std::cout << " as " << m.model;
        std::cout << "\n      " << m.reason << "\n";
        if (m.status == MaterialStatus::Tabulated)
            for (const auto& [part, why] : m.closed_forms)
                std::cout << "      " << part << ": no-table-needed: " << why << "\n";
        for (const std::string& n : m.notes) std::cout << "      note: " << n << "\n";
    }
}

// The sets above 10^8 cells (adaptive_plan.h), each printed as a warning
// naming the axis responsible; with `refuse` (a run, not --dry-run, without
// --tabulate-closed-forms asking for large tables) the first is refused
// (docs/scenes.md).
void warn_large_sets(const ScenePlan& plan, const std::vector<Spec>& specs, bool refuse) {
    std::vector<std::string> large;
    for (std::size_t k = 0; k < plan.sets.size(); ++k)
        if (const std::string w = large_plan_warning(specs[k]); !w.empty())
            large.push_back(plan.sets[k].id + " (" + plan.sets[k].model + " " + plan.sets[k].purpose + "): " + w);
    for (const std::string& w : large) std::cout << "  warning: " << w << "\n";
    if (refuse && !large.empty())
        throw InputError("table set " + large.front() +
                         ". scene refuses plans above 1e+08 cells: relax --accuracy, tabulate less (--for), "
                         "or pass --tabulate-closed-forms to accept large tables; nothing computed or written");
}

}  // namespace

void register_scene(CLI::App& app) {
    auto* cmd = app.add_subcommand(
        "scene",
        "read a pbrt-v3/v4 scene, a Mitsuba 0.6/3 XML scene or a brdftab material list (TOML), "
        "map each material to a brdftab model with the renderer's conventions, and tabulate "
        "only what the materials need: one HDF5 file plus a JSON manifest binding each "
        "material to its table (docs/scenes.md)");
    struct State {
        std::string scene, output, manifest, format, purpose = "all", presets, max_memory;
        double accuracy = 1e-3, budget = 0;
        bool dry_run = false, quiet = false, no_plan = false, no_certify = false;
        bool tabulate_closed_forms = false;
        ComputeOptions compute;
    };
    auto state = std::make_shared<State>();
    cmd->add_option("SCENE_FILE", state->scene,
                    "scene file: .pbrt (pbrt-v3/v4), .xml (Mitsuba), .toml (brdftab material list)")
        ->required();
    cmd->add_option("-o,--output", state->output,
                    "HDF5 file for the tables (default: <scene stem>.tables.h5 in the current "
                    "directory)")
        ->check(non_empty_path());
    cmd->add_option("--manifest", state->manifest,
                    "JSON manifest (default: the output with .json instead of .h5)")
        ->check(non_empty_path());
    cmd->add_option("--format", state->format, "pbrt | mitsuba | toml (default: from the extension)");
    cmd->add_option("--for", state->purpose,
                    "bsdf: BSDF tables for rendering and sampling; albedo: directional/average "
                    "albedo tables for energy compensation; all: both (default)");
    cmd->add_option("--accuracy", state->accuracy,
                    "target max total relative error of each table set (default 1e-3): the "
                    "planner (brdftab plan) chooses node counts, samples and stored type with "
                    "short pilot runs; also the integration tolerance of sets it cannot plan");
    cmd->add_option("--budget", state->budget,
                    "instead of --accuracy: the most accurate plans predicted to finish within "
                    "SECONDS in all (split evenly over the table sets)");
    cmd->add_flag("--no-plan", state->no_plan,
                  "skip the planner: every set keeps its fixed template resolution "
                  "(docs/scenes.md), with --accuracy as the integration tolerance");
    cmd->add_option("--presets", state->presets,
                    "directory of the preset specs, to report the cells saved against them "
                    "(default: the installed presets, if found)");
    cmd->add_flag("--dry-run", state->dry_run,
                  "print the materials and the planned tables; compute and write nothing");
    cmd->add_flag("--no-certify", state->no_certify,
                  "skip the certificates (off-grid probes of every written table against the "
                  "model, stored in the file and the manifest)");
    cmd->add_flag("--tabulate-closed-forms", state->tabulate_closed_forms,
                  "BSDF tables also for materials whose BSDF is a closed form the renderer "
                  "evaluates itself (rough dielectrics), which by default get only their albedos");
    cmd->add_flag("-q,--quiet", state->quiet, "no progress display");
    cmd->add_option("--max-memory", state->max_memory,
                    "refuse (exit 2) before computing when the tables are estimated to need more "
                    "memory than this (bytes, or with K/M/G/T); default: MemAvailable, as generate");
    state->compute.add_to(*cmd, false);
    cmd->callback([state, cmd] {
        namespace fs = std::filesystem;
        const State& st = *state;
        ScenePlanSettings settings;
        settings.purpose = parse_scene_purpose(st.purpose);
        settings.accuracy = st.accuracy;
        settings.tabulate_closed_forms = st.tabulate_closed_forms;
        const std::vector<SceneMaterial> materials = read_scene_materials(st.scene, st.format);
        if (st.budget < 0 || !std::isfinite(st.budget))
            throw InputError("--budget must be a positive number of seconds");
        if (st.budget > 0 && cmd->count("--accuracy") > 0)
            throw InputError("give --accuracy or --budget, not both");
        if (st.budget > 0 && st.no_plan)
            throw InputError("--budget needs the planner: drop --no-plan");
        ScenePlan plan = plan_scene_tables(materials, settings);
        std::unique_ptr<Backend> backend;
        if (!st.no_plan && !plan.sets.empty()) {
            backend = st.compute.make_backend();
            for (SceneTableSet& set : plan.sets) {
                double last = 0;
                auto progress = [&](const std::string& stage, const Progress& p) {
                    if (st.quiet || p.elapsed_seconds < 2 || p.elapsed_seconds - last < 2) return;
                    last = p.elapsed_seconds;
                    std::cerr << "scene: planning " << set.id << ": " << stage << " "
                              << static_cast<int>(100 * p.fraction) << "%\n";
                };
                plan_table_set(set, *backend, st.accuracy,
                               st.budget > 0 ? st.budget / plan.sets.size() : 0, progress);
            }
        }
        std::vector<Spec> specs;
        std::vector<double> set_cells;
        double cells = 0;
        for (const SceneTableSet& set : plan.sets) {
            specs.push_back(parse_spec_string(set.spec_text, "<scene table set " + set.id + ">"));
            specs.back().file = st.scene;
            set_cells.push_back(estimate_resources(specs.back(), specs.back().integration).cells);
            cells += set_cells.back();
        }
        const std::string out_path =
            !st.output.empty() ? st.output : fs::path(st.scene).stem().string() + ".tables.h5";
        const std::string manifest_path =
            !st.manifest.empty() ? st.manifest
                                 : (fs::path(out_path).replace_extension(".json")).string();

        // What was found, and what each material becomes.
        print_materials(st.scene, plan.materials);
        std::cout << plan.sets.size() << " table set(s), " << cells_text(cells) << ":\n";
        for (std::size_t k = 0; k < plan.sets.size(); ++k) {
            const SceneTableSet& set = plan.sets[k];
            std::cout << "  " << set.id << " " << set.model << " " << set.purpose << " ("
                      << cells_text(set_cells[k])
                      << "): ";
            for (std::size_t i = 0; i < set.materials.size(); ++i)
                std::cout << (i ? ", " : "") << set.materials[i];
            std::cout << "\n";
            if (set.planned) {
                std::ostringstream pred;
                pred.precision(3);
                pred << "      planned: predicted max total error " << set.predicted_error
                     << (set.purpose == "albedo" ? " (absolute)" : " (relative)")
                     << ", predicted time " << set.predicted_seconds << " s\n";
                std::cout << pred.str();
            }
            if (!set.plan_note.empty()) std::cout << "      " << set.plan_note << "\n";
        }
        warn_large_sets(plan, specs, !st.dry_run && !st.tabulate_closed_forms);
        // Against the presets of the same models (their whole parameter spaces).
        const std::string presets = find_presets_dir(st.presets);
        if (!presets.empty()) {
            // Preset time: the planner's cost model applied to the preset's
            // cells, with this run's measured cost per cell of the set that
            // maps to it (at the set's planned samples per cell, i.e. the
            // same integration accuracy); the preset keeps its own node
            // counts, so its interpolation error is its own, not E.
            std::map<std::string, double> preset_rate, preset_fixed;  // preset -> cost
            std::map<std::string, bool> preset_unpredicted;
            for (const SceneTableSet& set : plan.sets) {
                const std::string name = preset_for(set.model, set.purpose);
                if (name.empty()) continue;
                if (!set.planned) { preset_unpredicted[name] = true; continue; }
                preset_rate[name] = std::max(preset_rate[name], set.seconds_per_cell);
                preset_fixed[name] = std::max(preset_fixed[name], set.fixed_seconds);
            }
            std::set<std::string> used;
            double preset_cells = 0, preset_seconds = 0, scene_seconds = 0;
            bool all_predicted = true;
            for (const SceneTableSet& set : plan.sets) {
                all_predicted = all_predicted && set.planned;
                scene_seconds += set.predicted_seconds;
                const std::string name = preset_for(set.model, set.purpose);
                if (name.empty() || !used.insert(name).second) continue;
                const fs::path p = fs::path(presets) / (name + ".toml");
                if (!fs::exists(p)) continue;
                Spec preset = parse_spec_file(p.string());
                const double c = estimate_resources(preset, preset.integration).cells;
                preset_cells += c;
                if (preset_unpredicted.count(name) || !preset_rate.count(name))
                    all_predicted = false;
                else
                    preset_seconds += preset_fixed[name] + c * preset_rate[name];
            }
            if (preset_cells > 0) {
                std::cout << "the presets covering these models (" << presets << ") hold "
                          << cells_text(preset_cells);
                if (all_predicted)
                    std::cout << ", predicted " << seconds_text(preset_seconds);
                std::cout << "; this scene needs " << cells_text(cells);
                if (all_predicted) std::cout << ", predicted " << seconds_text(scene_seconds);
                std::cout << "\n";
                if (all_predicted)
                    std::cout << "  (preset time: the planner's cost model applied to the presets' "
                                 "cells, with this run's measured cost per cell at the planned "
                                 "samples; the presets keep their own node counts)\n";
                else
                    std::cout << "  (no time comparison: a set was not planned, so its cost per "
                                 "cell was not measured)\n";
            }
        }
        if (st.dry_run) {
            std::cout << "dry run: nothing computed or written\n";
            return;
        }
        if (plan.sets.empty()) {
            std::cout << "no material needs a table; nothing written\n";
            return;
        }
        check_output_writable(out_path);
        check_output_writable(manifest_path);
        const OutputLock lock(out_path), manifest_lock(manifest_path);  // one writer of each
        std::vector<IntegrationSettings> set_settings;
        for (const Spec& spec : specs) set_settings.push_back(st.compute.apply(spec.integration));
        check_scene_resources(specs, set_settings, out_path,
                              st.max_memory.empty() ? 0 : parse_byte_size(st.max_memory, "--max-memory"));
        if (!backend) backend = st.compute.make_backend();
        std::cerr << "writing " << fs::absolute(out_path).lexically_normal().string() << " and "
                  << fs::absolute(manifest_path).lexically_normal().string() << " on "
                  << backend->device_name() << "\n";
        // Streamed, as `generate`: each set's tables in chunks straight into
        // one file, which appears only when every set is done.
        std::size_t written = 0;
        {
            TableFileWriter writer(out_path);
            for (std::size_t k = 0; k < specs.size(); ++k) {
                TableProgress progress(st.quiet, plan.sets[k].id + " ");
                progress.sampled = [&](const TableSpec& t) {
                    return table_is_sampled(specs[k], t, set_settings[k].method);
                };
                written += generate_into(specs[k], *backend, set_settings[k], writer,
                                         progress.callback()).size();
                progress.finish();
            }
            writer.commit();
        }
        // Certificates: each table probed off-grid against the mapped model
        // (host/plan/certify.h), stored in the file and the manifest.
        std::vector<std::string> failed_tables;  // certificates that missed their target
        if (!st.no_certify) {
            for (SceneTableSet& set : plan.sets) {
                double last = 0;
                auto progress = [&](const std::string& stage, const Progress& p) {
                    if (st.quiet || p.elapsed_seconds < 2 || p.elapsed_seconds - last < 2) return;
                    last = p.elapsed_seconds;
                    std::cerr << "scene: " << stage << " " << static_cast<int>(100 * p.fraction) << "%\n";
                };
                const double target =
                    st.budget > 0 && set.planned ? set.predicted_error : st.accuracy;
                certify_table_set(set, out_path, *backend, target, progress);
                for (const SceneTableSet::TableCertificate& c : set.certificates) {
                    // Digits enough to show a miss (0.0010013 against 0.001).
                    const auto [max_text, target_text] = compared_text(c.max_error, c.target);
                    std::cout << "  certified " << c.table << ": max total error " << max_text
                              << (set.purpose == "albedo" ? " (absolute)" : " (relative)") << ", target "
                              << target_text << ": " << (c.passed ? "passed" : "FAILED")
                              << (c.how == "measured" ? "" : " (" + c.how + ")") << "\n";
                    if (!c.passed) failed_tables.push_back(c.table);
                }
            }
        }
        write_text_atomically(manifest_path,
                              scene_manifest(plan, st.scene, out_path).dump(2) + "\n");
        std::cout << "wrote " << out_path << " (" << written << " tables) and "
                  << manifest_path << "\n";
        // As `certify` and `generate --accuracy`: the files stay written (the
        // manifest records `passed`), the exit code is 1.
        if (!failed_tables.empty()) {
            std::string names;
            for (const std::string& t : failed_tables) names += (names.empty() ? "" : ", ") + t;
            throw Error(std::to_string(failed_tables.size()) + " certificate(s) missed the target (" + names +
                        "); " + out_path + " and " + manifest_path +
                        " were written with passed = false; plan the sets (without --no-plan), or leave the "
                        "planner a margin with a smaller --accuracy");
        }
    });
}

}  // namespace brdftab::cli
