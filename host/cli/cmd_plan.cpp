// plan: pilot runs, error and cost model, Pareto table and choice
// (host/plan/plan.h, docs/planning.md).
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

#include "host/cli/cli_common.h"
#include "host/cli/commands.h"
#include "host/core/atomic_file.h"
#include "host/core/error.h"
#include "host/core/text.h"
#include "host/plan/adaptive_plan.h"
#include "host/plan/certify.h"
#include "host/plan/plan.h"
#include "host/spec/spec.h"

namespace brdftab::cli {

namespace {

struct PlanArgs {
    std::string spec, output, table;
    std::optional<double> accuracy, budget;
    bool absolute = false, json = false, quiet = false;
    bool place_nodes = false;  // --place-nodes (host/plan/node_placement.h)
    bool as_written = false;   // --as-written: predict the spec's own plan (predict_as_written)
    bool no_verify = false;    // --no-verify: keep the fitted prediction (certify.h verify_plan)
    double verify_limit = 0.25;  // --verify-limit: largest fraction of a table's cells a verification computes
    double abs_floor = 0;
    std::string interpolation = "linear";
    // tensor | adaptive | auto; empty: the spec's [output] representation,
    // auto with a target (docs/adaptive.md, "Choosing the representation").
    std::string representation;
    ComputeOptions compute;
};

std::string sci(double v) {
    if (!std::isfinite(v)) return "inf";
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2e", v);
    return buf;
}

std::string fit_text(const PowerFit& f) {
    if (!f.valid) return "no fit (exact or below noise)";
    char buf[64];
    std::snprintf(buf, sizeof buf, "C=%.3g p=%.2f", f.c, f.p);
    return buf;
}

std::string counts_text(const Candidate& c, const std::vector<TablePilot>& pilots) {
    std::string s;
    for (std::size_t i = 0; i < c.tables.size(); ++i) {
        if (i) s += "; ";
        if (pilots.size() > 1) s += c.tables[i].table + ":";
        for (std::size_t a = 0; a < c.tables[i].counts.size(); ++a)
            s += (a ? "x" : "") + std::to_string(c.tables[i].counts[a]);
    }
    return s;
}

std::string method_text(const Candidate& c) {
    if (c.method == Method::MonteCarlo || c.method == Method::Rqmc)
        return to_string(c.method) + " " + std::to_string(c.samples);
    return to_string(c.method);
}

nlohmann::json adaptive_json(const AdaptivePlan& ap) {
    nlohmann::json j;
    j["accuracy"] = ap.accuracy;
    j["measure"] = ap.absolute ? "absolute" : "relative";
    j["predicted_values"] = ap.values;
    j["predicted_seconds"] = ap.seconds;
    j["predicted_error"] = ap.error_max;
    j["pilot_seconds"] = ap.pilot_seconds;
    j["meets"] = ap.meets;
    if (!ap.why.empty()) j["why"] = ap.why;
    j["tables"] = nlohmann::json::array();
    for (const AdaptiveTablePrediction& t : ap.tables) {
        nlohmann::json e = {{"table", t.table},           {"predicted_values", t.values},
                            {"predicted_evaluations", t.evaluations}, {"predicted_seconds", t.seconds},
                            {"exponent", t.exponent},     {"max_values", t.max_values},
                            {"within_budget", t.within_budget}, {"lower_bound", t.lower_bound}};
        e["pilots"] = nlohmann::json::array();
        for (const AdaptivePilotRun& r : t.runs)
            e["pilots"].push_back({{"target", r.target}, {"values", r.values}, {"evaluations", r.evaluations},
                                   {"patches", r.leaves}, {"seconds", r.seconds},
                                   {"largest_probe_error", r.estimated_max}, {"budget_reached", r.budget_hit}});
        j["tables"].push_back(e);
    }
    return j;
}

// The verification of a plan (docs/planning.md "Verified plans"), as JSON.
// A plan's JSON (candidate_json) with each verified table's predicted
// error replaced by its verification's (the fitted one kept as fitted_max).
// One predicted_error object: max/rms become the verified ones, the fitted
// ones are kept as fitted_max/fitted_rms.
void replace_predicted(nlohmann::json& e, double max, double rms) {
    e["fitted_max"] = e["max"];
    e["fitted_rms"] = e["rms"];
    e["max"] = max;
    e["rms"] = rms;
}

void apply_verification(nlohmann::json& plan, const PlanVerification& v) {
    if (plan.contains("predicted_error") && plan["predicted_error"].is_object() && v.verified > 0)
        replace_predicted(plan["predicted_error"], v.error_max, v.error_rms);
    if (!plan.contains("tables") || !plan["tables"].is_array()) return;
    for (std::size_t i = 0; i < v.tables.size() && i < plan["tables"].size(); ++i) {
        nlohmann::json& e = plan["tables"][i]["predicted_error"];
        if (!e.is_object()) continue;
        e["verified"] = v.tables[i].verified;
        if (!v.tables[i].verified) continue;
        replace_predicted(e, v.tables[i].certificate.max_error, v.tables[i].certificate.rms_error);
    }
    // Recombined entries: their bound from the terms' verified errors.
    for (std::size_t k = 0; k < v.recombined.size(); ++k) {
        const std::size_t i = v.tables.size() + k;
        if (i >= plan["tables"].size()) break;
        nlohmann::json& e = plan["tables"][i]["predicted_error"];
        if (!e.is_object()) continue;
        const PlanVerification::Recombined& r = v.recombined[k];
        e["verified"] = r.verified;
        e["from_verified_terms"] = r.from_verified_terms;
        replace_predicted(e, r.max, r.rms);
    }
}

nlohmann::json verification_json(const PlanVerification& v) {
    nlohmann::json j;
    j["fitted_max"] = v.fitted_max;
    j["fitted_rms"] = v.fitted_rms;
    j["max"] = v.error_max;
    j["rms"] = v.error_rms;
    j["tables_verified"] = v.verified;
    j["touched_cells"] = v.touched_cells;
    j["computed_cells"] = v.computed_cells;
    j["table_cells"] = v.table_cells;
    j["seconds"] = v.seconds;
    j["tables"] = nlohmann::json::array();
    for (const SparseCertificate& t : v.tables) {
        nlohmann::json e;
        e["verified"] = t.verified;
        e["table_cells"] = t.table_cells;
        e["touched_cells"] = t.touched_cells;
        e["computed_cells"] = t.computed_cells;
        e["seconds"] = t.seconds;
        if (t.verified) {
            const Certificate& c = t.certificate;
            e["table"] = c.table;
            e["max"] = c.max_error;
            e["rms"] = c.rms_error;
            e["fitted_max"] = c.predicted_max;
            e["probes"] = c.probes;
            e["reference_noise"] = c.reference_noise;
            nlohmann::json at = nlohmann::json::object();
            for (std::size_t a = 0; a < c.axis_names.size() && a < c.max_at.size(); ++a) at[c.axis_names[a]] = c.max_at[a];
            e["max_at"] = at;
            e["engine_seconds"] = t.compute_seconds;
        } else {
            e["why"] = t.why;
        }
        j["tables"].push_back(e);
    }
    j["recombined"] = nlohmann::json::array();
    for (const PlanVerification::Recombined& r : v.recombined)
        j["recombined"].push_back({{"table", r.table},
                                   {"max", r.max},
                                   {"rms", r.rms},
                                   {"fitted_max", r.fitted_max},
                                   {"fitted_rms", r.fitted_rms},
                                   {"verified", r.verified},
                                   {"from_verified_terms", r.from_verified_terms},
                                   {"touched_cells", r.sparse.touched_cells},
                                   {"computed_cells", r.sparse.computed_cells},
                                   {"why", r.sparse.why}});
    return j;
}

// Text lines of a verification, one per table.
void print_verification(const PlanVerification& v, const std::vector<TablePilot>& pilots, const char* what) {
    for (std::size_t i = 0; i < v.tables.size(); ++i) {
        const SparseCertificate& t = v.tables[i];
        const std::string name = i < pilots.size() ? pilots[i].table : std::string("?");
        if (t.verified) {
            const Certificate& c = t.certificate;
            std::cout << "verified " << what << " '" << name << "': max total error " << sci(c.max_error) << " (RMS "
                      << sci(c.rms_error) << "), fitted prediction " << sci(c.predicted_max) << "; sparse certificate, "
                      << c.probes << " probes reading " << t.touched_cells << " of " << t.table_cells << " cells ("
                      << number_text(100.0 * double(t.touched_cells) / double(std::max<std::size_t>(t.table_cells, 1)), 3)
                      << " %; " << t.computed_cells << " computed in " << t.engine_runs << " engine runs), "
                      << format_seconds(t.seconds) << "\n";
        } else {
            std::cout << "not verified " << what << " '" << name << "': " << t.why << "; the fitted prediction stands\n";
        }
    }
    for (const PlanVerification::Recombined& r : v.recombined) {
        if (r.verified) {
            const SparseCertificate& t = r.sparse;
            std::cout << "verified " << what << " '" << r.table << "' (recombined): max total error "
                      << sci(r.max) << " (RMS " << sci(r.rms) << "), bound from its terms "
                      << sci(t.certificate.predicted_max) << ", fitted prediction " << sci(r.fitted_max)
                      << "; sparse certificate, " << t.certificate.probes << " probes reading "
                      << t.touched_cells << " of " << t.table_cells << " cells, " << format_seconds(t.seconds)
                      << "\n";
            continue;
        }
        std::cout << "recombined " << what << " '" << r.table << "': max total error bound " << sci(r.max)
                  << " (RMS " << sci(r.rms) << ") from its terms' "
                  << (r.from_verified_terms ? "verified errors" : "errors (not every term verified)")
                  << ", fitted prediction " << sci(r.fitted_max);
        if (!r.sparse.why.empty()) std::cout << "; not verified itself: " << r.sparse.why;
        std::cout << "\n";
    }
}

// The state one `plan` run builds up step by step (run_plan).
struct PlanState {
    PlanTarget target;
    const char* measure = "relative";
    std::vector<std::size_t> indices;            // the planned tables
    std::vector<RecombinedGroup> groups;
    std::unique_ptr<Backend> backend;
    double last_shown = 0;                       // progress lines: the last one's time
    std::vector<TablePilot> pilots;
    std::vector<Candidate> all, front;
    std::optional<std::size_t> choice;           // in front
    std::optional<Candidate> written;            // --as-written
    std::string written_why;
    std::optional<Candidate> placed;             // --place-nodes
    std::vector<PlacedAxis> placements;
    std::optional<PlanVerification> verification;
    std::vector<std::string> verify_notes;
    int verify_corrections = 0;
    // The adaptive plan (adaptive_plan.h), its comparison with the tensor
    // choice, and why there is none (adaptive_note).
    std::optional<AdaptivePlan> adaptive;
    std::string adaptive_note;
    std::optional<RepresentationChoice> representation;
    std::vector<std::string> warnings;           // plans above kLargePlanCells
    std::string text;                            // the spec written by -o
};

// The target and the options' consistency (bad input: exit code 2).
PlanTarget plan_target(const PlanArgs& pa) {
    PlanTarget target;
    target.absolute = pa.absolute;
    target.accuracy = pa.accuracy;
    target.budget = pa.budget;
    target.interpolation = pa.interpolation == "cubic" ? Interpolation::Cubic : Interpolation::Linear;
    check_target(target);
    if (pa.abs_floor < 0 || !std::isfinite(pa.abs_floor))
        throw InputError("--abs-floor must be a finite number >= 0, got " + number_text(pa.abs_floor, 6));
    if (!pa.output.empty() && !target.accuracy && !target.budget)
        throw InputError("-o needs a target to choose a plan: give --accuracy E or --budget SECONDS");

    if (pa.as_written && (target.accuracy || target.budget || !pa.output.empty() || pa.place_nodes))
        throw InputError("--as-written predicts the spec's own plan: it excludes --accuracy, --budget, -o "
                         "and --place-nodes");
    if (pa.no_verify && !pa.as_written && !target.accuracy && !target.budget)
        throw InputError("--no-verify skips the verification of a chosen plan: it needs --accuracy, --budget "
                         "or --as-written");
    if (!(pa.verify_limit > 0 && pa.verify_limit <= 1))
        throw InputError("--verify-limit must be a fraction in (0, 1], got " + number_text(pa.verify_limit, 6));
    return target;
}

// The tables to plan (--table), checked against the spec.
std::vector<std::size_t> planned_tables(const PlanArgs& pa, const Spec& spec) {
    if (!spec.errors.empty() || !spec.inverted.empty())
        throw InputError(pa.spec + ": plan does not handle [[errors]] or [[inverted]] "
                         "tables yet (their tables must share nodes); plan a copy of the spec without them");
    std::vector<std::size_t> indices;
    for (std::size_t i = 0; i < spec.tables.size(); ++i)
        if (pa.table.empty() || spec.tables[i].name == pa.table) indices.push_back(i);
    if (indices.empty()) {
        std::string names;
        for (const TableSpec& t : spec.tables) names += (names.empty() ? "" : ", ") + t.name;
        throw InputError(pa.spec + ": no table '" + pa.table + "'; tables: " + names);
    }
    if (!pa.table.empty() && !pa.output.empty() && spec.tables.size() > 1)
        throw InputError("-o with --table: the written spec would keep the other tables unplanned; "
                         "plan the whole spec, or a copy with that table only");
    return indices;
}

// Places the chosen plan's nodes (--place-nodes).
void place(const PlanArgs& pa, PlanState& st) {
    st.placed.reset();
    st.placements.clear();
    if (st.choice && pa.place_nodes) {
        st.placed = st.front[*st.choice];
        st.placements = place_plan_nodes(st.pilots, *st.placed, st.target);
    }
}

void verify_plans(const PlanArgs& pa, const Spec& spec, PlanState& st) {
    PlanTarget& target = st.target;
    std::vector<TablePilot>& pilots = st.pilots;
    const std::vector<std::size_t>& indices = st.indices;
    std::optional<PlanVerification>& verification = st.verification;
    std::vector<std::string>& verify_notes = st.verify_notes;
    int& verify_corrections = st.verify_corrections;
    std::optional<std::size_t>& choice = st.choice;
    double& last_shown = st.last_shown;
    const std::optional<Candidate>& written = st.written;
    const std::optional<Candidate>& placed = st.placed;
    // Verification (docs/planning.md "Verified plans"): the plan's tables
    // measured by sparse certificates, on the cells their probes touch,
    // computed as `generate` would.  With --accuracy a missed target corrects
    // the fitted model (correct_error_model, as generate --accuracy refines)
    // and the plan is chosen again, at most kVerifyRounds times.
    constexpr int kVerifyRounds = 2;
    const ProgressFn verify_progress = [&](const Progress& p) {
        if (pa.quiet || p.elapsed_seconds < 2 || p.elapsed_seconds - last_shown < 2) return;
        last_shown = p.elapsed_seconds;
        std::cerr << "plan: verify: " << p.cells_done << " cells computed, " << format_seconds(p.elapsed_seconds)
                  << "\n";
    };
    auto verify = [&](const Candidate& c, const Spec& planned) {
        last_shown = 0;
        SparseCertifyOptions so;
        so.max_touched_fraction = pa.verify_limit;
        so.cheap_table_seconds = 5.0;  // docs/planning.md "Verified plans"
        return verify_plan(planned, indices, c, pilots, *st.backend, pa.compute.apply(planned.integration), target,
                           pa.abs_floor, so, verify_progress);
    };
    if (!pa.no_verify && pa.as_written && written) verification = verify(*written, spec);
    while (!pa.no_verify && choice) {
        const Candidate& c = placed ? *placed : st.front[*choice];
        const Spec planned = parse_spec_string(planned_spec_text(spec, indices, c, {}), pa.spec);
        verification = verify(c, planned);
        if (!target.accuracy || verification->verified == 0 || verification->error_max <= *target.accuracy) break;
        if (verify_corrections >= kVerifyRounds) {
            verify_notes.push_back("the verification missed --accuracy " + sci(*target.accuracy) + " after " +
                                   std::to_string(kVerifyRounds) + " corrections of the fitted model; the plan is the last one chosen");
            break;
        }
        std::vector<const Certificate*> certs;
        for (const SparseCertificate& t : verification->tables) certs.push_back(t.verified ? &t.certificate : nullptr);
        correct_error_model(pilots, target, c, certs, [&](const std::string& m) { verify_notes.push_back(m); });
        ++verify_corrections;
        st.all = make_recombined_candidates(pilots, target, st.groups);
        st.front = pareto_front(st.all);
        choice = choose_plan(st.front, target);
        place(pa, st);
        if (!choice) {
            verification.reset();
            verify_notes.push_back("with the fitted model corrected by the verification no candidate is predicted to reach "
                                   "--accuracy " + sci(*target.accuracy));
        }
    }
    if (verification && target.accuracy && choice && verify_corrections > 0 &&
        verification->error_max <= *target.accuracy)
        verify_notes.push_back("the plan was chosen again after " + std::to_string(verify_corrections) +
                               " correction(s) of the fitted model; its verification reaches --accuracy " +
                               sci(*target.accuracy));
}

// Text lines of the adaptive plan and the representation chosen.
void print_adaptive_text(const PlanState& st) {
    if (st.adaptive) {
        const AdaptivePlan& ap = *st.adaptive;
        for (const AdaptiveTablePrediction& t : ap.tables) {
            std::cout << "adaptive '" << t.table << "': pilots";
            for (const AdaptivePilotRun& r : t.runs)
                std::cout << " " << r.values << "@" << sci(r.target) << (r.budget_hit ? "(budget)" : "");
            std::cout << " -> " << (t.lower_bound ? "at least " : "about ") << format_count(t.values)
                      << " values at " << sci(ap.accuracy);
            if (!t.lower_bound) std::cout << " (values ~ E^-" << number_text(t.exponent, 3) << ")";
            std::cout << ", max_values " << t.max_values << "\n";
        }
        std::cout << "adaptive plan: " << (ap.tables.empty() || !ap.tables.front().lower_bound ? "about " : "at least ")
                  << format_count(ap.values) << " values, predicted max error " << sci(ap.error_max)
                  << " (the refinement's target), predicted time " << sci(ap.seconds) << " s; pilots "
                  << format_seconds(ap.pilot_seconds) << (ap.meets ? "" : "; does not qualify: " + ap.why) << "\n";
    } else if (!st.adaptive_note.empty()) {
        std::cout << "adaptive plan: none (" << st.adaptive_note << ")\n";
    }
    if (st.representation)
        std::cout << "representation: " << (st.representation->any ? "" : "none: ") << st.representation->why
                  << "\n";
}

// The adaptive plan beside the tensor one (docs/adaptive.md, "Choosing the
// representation"): with --accuracy E at E; with --budget at the tensor
// choice's predicted error, meeting the budget when its predicted time does.
void compare_adaptive(const PlanArgs& pa, const Spec& spec, PlanState& st) {
    std::string rep = pa.representation;
    if (rep.empty()) rep = spec.output.representation_given ? spec.output.representation : "auto";
    if (rep == "tensor" || (!st.target.accuracy && !st.target.budget)) return;
    const std::optional<Candidate> tensor =
        st.choice ? std::optional<Candidate>(st.placed ? *st.placed : st.front[*st.choice]) : std::nullopt;
    double accuracy = st.target.accuracy ? *st.target.accuracy : tensor ? tensor->error_max : 0;
    if (st.verification && st.verification->verified > 0 && st.target.budget) accuracy = st.verification->error_max;
    if (!(accuracy > 0)) {
        st.adaptive_note = "no tensor plan within the budget gives an error to aim the adaptive plan at";
        return;
    }
    if (!spec.recombined.empty()) {
        st.adaptive_note = "adaptive tables do not handle [[recombined]] tables";
        return;
    }
    Spec sub = spec;
    sub.tables.clear();
    for (std::size_t i : st.indices) sub.tables.push_back(spec.tables[i]);
    AdaptivePlanOptions ao;
    if (tensor && rep == "auto") ao.stop_values = plan_cells(*tensor);
    const IntegrationSettings settings = pa.compute.apply(spec.integration);
    check_settings(settings);
    try {
        st.adaptive = predict_adaptive_plan(
            sub, *st.backend, settings, AdaptiveSpecSettings{}, accuracy, st.target.absolute, pa.abs_floor, ao,
            [&](const std::string& table, const AdaptivePilotRun& r) {
                if (!pa.quiet)
                    std::cerr << "plan: adaptive pilot '" << table << "' at " << sci(r.target) << ": " << r.values
                              << " values, " << format_seconds(r.seconds) << "\n";
            });
    } catch (const InputError& e) {
        st.adaptive_note = e.what();
        return;
    }
    AdaptivePlan ap = *st.adaptive;
    if (st.target.budget && ap.meets && ap.seconds > *st.target.budget) {
        ap.meets = false;
        ap.why = "predicted time " + format_seconds(ap.seconds) + " is beyond --budget";
        st.adaptive = ap;
    }
    if (rep == "adaptive") {
        RepresentationChoice c;
        c.any = ap.meets;
        c.adaptive = ap.meets;
        c.why = ap.meets ? "adaptive (--representation adaptive)" : "the adaptive plan does not qualify: " + ap.why;
        st.representation = c;
        return;
    }
    st.representation = choose_representation(tensor, &ap);
}

// The planned spec that -o writes (empty without a choice or -o).
std::string planned_output_text(const PlanArgs& pa, const Spec& spec, const PlanState& st) {
    std::string text;
    const Candidate* chosen = st.choice ? (st.placed ? &*st.placed : &st.front[*st.choice]) : nullptr;
    if (st.representation && st.representation->adaptive && !pa.output.empty()) {
        const AdaptivePlan& ap = *st.adaptive;
        text = adaptive_spec_text(
            spec, ap.accuracy, ap.absolute,
            {"Planned by `brdftab plan` from " + pa.spec + ": adaptive tables for max " + std::string(st.measure) +
                 " error <= " + sci(ap.accuracy) + " (device " + st.backend->device_name() + ").",
             "Predicted: about " + format_count(ap.values) + " values in all, time " + sci(ap.seconds) +
                 " s; " + st.representation->why + ".  docs/adaptive.md"});
        parse_spec_string(text, pa.output);
        return text;
    }
    if (chosen && !pa.output.empty()) {
        const Candidate& c = *chosen;
        std::vector<std::string> header = {
            "Planned by `brdftab plan` from " + pa.spec + " for " +
                (st.target.accuracy ? "max total " + std::string(st.measure) + " error <= " + sci(*st.target.accuracy)
                                    : "a time budget of " + sci(*st.target.budget) + " s") +
                " (" + pa.interpolation + " interpolation, device " + st.backend->device_name() + ").",
            "Predicted: max total error " + sci(c.error_max) + ", RMS " + sci(c.error_rms) + " (" +
                st.measure + "), engine time " + sci(c.seconds) + " s.  docs/planning.md"};
        if (st.verification)
            header.push_back("Verified: max total error " + sci(st.verification->error_max) + ", RMS " +
                             sci(st.verification->error_rms) + " (sparse certificate of " +
                             std::to_string(st.verification->verified) + " table(s)).");
        text = planned_spec_text(spec, st.indices, c, header);
        parse_spec_string(text, pa.output);  // the written spec must parse (throws: nothing written)
    }
    return text;
}

void print_plan_json(const PlanArgs& pa, const PlanState& st) {
    const PlanTarget& target = st.target;
    const char* measure = st.measure;
    const std::vector<TablePilot>& pilots = st.pilots;
    const std::vector<Candidate>& front = st.front;
    const std::optional<std::size_t>& choice = st.choice;
    const std::optional<Candidate>& written = st.written;
    const std::optional<PlanVerification>& verification = st.verification;
    nlohmann::json j;
    j["spec"] = pa.spec;
    j["device"] = st.backend->device_name();
    j["measure"] = measure;
    j["interpolation"] = pa.interpolation;
    if (target.accuracy) j["accuracy"] = *target.accuracy;
    if (target.budget) j["budget"] = *target.budget;
    j["pilots"] = nlohmann::json::array();
    for (const TablePilot& p : pilots) j["pilots"].push_back(pilot_json(p));
    j["plans"] = nlohmann::json::array();
    for (const Candidate& c : front) j["plans"].push_back(candidate_json(c, pilots));
    if (choice) {
        j["choice"] = candidate_json(front[*choice], pilots);
        j["choice"]["index"] = *choice;
        j["predicted_error"] = front[*choice].error_max;
        j["fitted_error"] = front[*choice].error_max;
        j["predicted_seconds"] = front[*choice].seconds;
        if (verification && !pa.as_written) {
            j["choice"]["verification"] = verification_json(*verification);
            apply_verification(j["choice"], *verification);
            j["predicted_error"] = verification->error_max;
        }
        if (pa.place_nodes) {
            j["placed_nodes"] = nlohmann::json::array();
            for (const PlacedAxis& r : st.placements)
                j["placed_nodes"].push_back({{"table", r.table}, {"axis", r.axis}, {"count", r.count},
                                             {"predicted_max", r.predicted_max},
                                             {"uniform_max", r.uniform_max},
                                             {"spacing_max", r.spacing_max},
                                             {"used", r.predicted_max < r.spacing_max}});
        }
    } else {
        j["choice"] = nullptr;
    }
    if (pa.as_written) {
        j["as_written"] = written ? candidate_json(*written, pilots) : nlohmann::json(st.written_why);
        if (written) {
            j["predicted_error"] = written->error_max;
            j["fitted_error"] = written->error_max;
            j["predicted_seconds"] = written->seconds;
            if (verification) {
                j["as_written"]["verification"] = verification_json(*verification);
                apply_verification(j["as_written"], *verification);
                j["predicted_error"] = verification->error_max;
            }
        }
    }
    if (st.adaptive)
        j["adaptive"] = adaptive_json(*st.adaptive);
    else if (!st.adaptive_note.empty())
        j["adaptive"] = {{"why", st.adaptive_note}};
    if (st.representation)
        j["representation"] = {{"choice", st.representation->any
                                              ? nlohmann::json(st.representation->adaptive ? "adaptive" : "tensor")
                                              : nlohmann::json(nullptr)},
                               {"why", st.representation->why}};
    j["warnings"] = st.warnings;
    j["verified"] = verification.has_value() && verification->verified > 0;
    j["verification_seconds"] = verification ? verification->seconds : 0.0;
    j["verification_corrections"] = st.verify_corrections;
    j["verification_notes"] = st.verify_notes;
    std::cout << j.dump(2) << "\n";
}

// The pilots' measurements and fits, as text.
void print_pilots_text(const std::vector<TablePilot>& pilots, const PlanTarget& target, const char* measure) {
    for (const TablePilot& p : pilots) {
        std::cout << "pilot '" << p.table << "' (" << p.quantity << "): " << p.pilot_evaluations
                  << " direct evaluations, " << format_seconds(p.pilot_seconds) << "; max |value| "
                  << sci(p.max_value) << ", relative floor " << sci(p.rel_floor) << "\n";
        const std::vector<AxisFit>& fits =
            target.interpolation == Interpolation::Linear ? p.linear : p.cubic;
        for (const AxisFit& f : fits) {
            std::cout << "  axis " << std::left << std::setw(8) << f.axis << std::right;
            if (!f.planned) std::cout << " explicit nodes (kept)";
            std::cout << " counts";
            for (const LevelErrors& l : f.levels) std::cout << " " << l.count;
            std::cout << ": max " << measure << " error";
            for (const LevelErrors& l : f.levels)
                std::cout << " " << sci(target.absolute ? l.max_abs : l.max_rel);
            std::cout << "  -> " << fit_text(target.absolute ? f.max_abs : f.max_rel);
            // An explicit axis whose measurement is mostly the pilot's
            // noise is predicted without it (plan.cpp, axis_error).
            const LevelErrors& finest = f.levels.back();
            if (!f.planned && !p.variance_unseen && noise_dominated(finest))
                std::cout << " (below 3x the pilot's noise " << sci(finest.noise) << "; without it "
                          << sci(target.absolute ? finest.denoised_max_abs : finest.denoised_max_rel) << ")";
            std::cout << "\n";
        }
        for (const IntegrationFit& f : p.integration) {
            if (f.method == Method::ClosedForm) {
                std::cout << "  closed form: " << sci(f.seconds_per_cell) << " s per cell, "
                          << sci(p.overhead_seconds) << " s per run\n";
            } else if (f.method == Method::Quadrature) {
                std::cout << (f.reference_nodes > 0
                                  ? "  quadrature: rule error (against " + number_text(f.reference_nodes) +
                                        " nodes) max "
                                  : std::string("  quadrature: two-rule difference max "))
                          << sci(target.absolute ? f.max_abs.front() : f.max_rel.front()) << ", "
                          << sci(f.seconds_per_cell) << " s per cell\n";
            } else {
                const PowerFit& q = target.absolute ? f.fit_max_abs : f.fit_max_rel;
                std::cout << "  " << to_string(f.method) << ": max stderr";
                for (std::size_t k = 0; k < f.samples.size(); ++k)
                    std::cout << " " << sci(target.absolute ? f.max_abs[k] : f.max_rel[k]) << "@"
                              << f.samples[k];
                std::cout << "  -> q=" << (q.valid ? number_text(-q.p, 3) : "?") << ", "
                          << sci(f.seconds_per_sample) << " s per sample\n";
            }
        }
        if (p.variance_unseen)
            std::cout << "  warning: at some pilot budget every cell's samples were all equal (stderr 0) "
                         "although the values are not all 0: rare events, too few for the standard "
                         "errors to measure the noise; the integration term may be far too small "
                         "(docs/planning.md)\n";
    }
}

void print_pareto_text(const PlanState& st) {
    const std::vector<TablePilot>& pilots = st.pilots;
    const std::vector<Candidate>& front = st.front;
    const std::optional<std::size_t>& choice = st.choice;
    // A small table: about 12 rows spread over the front, the first and
    // last, and the choice with its neighbours (--json lists every plan).
    const std::size_t step = (front.size() + 11) / 12;
    auto shown = [&](std::size_t i) {
        if (i == 0 || i + 1 == front.size() || i % std::max<std::size_t>(step, 1) == 0) return true;
        return choice && i + 1 >= *choice && i <= *choice + 1;
    };
    std::cout << "Pareto plans (" << front.size() << " of " << st.all.size() << " candidates"
              << (step > 1 ? "; a selection, --json lists all" : "") << "):\n";
    std::cout << "   #  nodes                 method        type     err max   err rms   seconds\n";
    bool gap = false;
    for (std::size_t i = 0; i < front.size(); ++i) {
        if (!shown(i)) {
            if (!gap) std::cout << "   ...\n";
            gap = true;
            continue;
        }
        gap = false;
        const Candidate& c = front[i];
        std::cout << (choice && *choice == i ? " * " : "   ") << std::left << std::setw(3) << i
                  << std::setw(22) << counts_text(c, pilots) << " " << std::setw(13)
                  << method_text(c) << " " << std::setw(8) << stored_type_name(c.stored_type)
                  << std::right << " " << sci(c.error_max) << "  " << sci(c.error_rms) << "  "
                  << sci(c.seconds) << "\n";
    }
}

void print_plan_text(const PlanArgs& pa, const PlanState& st) {
    const PlanTarget& target = st.target;
    const char* measure = st.measure;
    const std::vector<TablePilot>& pilots = st.pilots;
    const std::vector<Candidate>& front = st.front;
    const std::optional<std::size_t>& choice = st.choice;
    const std::optional<Candidate>& written = st.written;
    const std::optional<PlanVerification>& verification = st.verification;
    std::cout << "plan " << pa.spec << " on " << st.backend->device_name() << ": " << measure
              << " errors, " << pa.interpolation << " interpolation\n";
    print_pilots_text(pilots, target, measure);
    print_pareto_text(st);
    if (choice) {
        const Candidate& c = front[*choice];
        std::cout << "choice #" << *choice << ": nodes " << counts_text(c, pilots) << ", "
                  << method_text(c) << ", " << stored_type_name(c.stored_type)
                  << "; predicted max total error " << sci(c.error_max) << " (RMS "
                  << sci(c.error_rms) << "), predicted time " << sci(c.seconds) << " s\n";
    }
    if (pa.as_written && written) {
        const Candidate& c = *written;
        std::cout << "as written: nodes " << counts_text(c, pilots) << ", " << method_text(c) << ", "
                  << stored_type_name(c.stored_type) << "; predicted max total error " << sci(c.error_max)
                  << " (RMS " << sci(c.error_rms) << "), predicted time " << sci(c.seconds) << " s\n";
    } else if (pa.as_written) {
        std::cout << "as written: no prediction (" << st.written_why << ")\n";
    }
    for (const std::string& n : st.verify_notes) std::cout << "verification: " << n << "\n";
    print_adaptive_text(st);
    for (const std::string& w : st.warnings) std::cout << "warning: " << w << "\n";
    if (verification) {
        print_verification(*verification, pilots, pa.as_written ? "as written" : "choice");
        if (verification->verified > 0)
            std::cout << "verified " << (pa.as_written ? "as written" : "choice") << ": max total error "
                      << sci(verification->error_max) << " (RMS " << sci(verification->error_rms)
                      << "), fitted prediction " << sci(verification->fitted_max) << "\n";
    } else if (pa.no_verify && (choice || written)) {
        std::cout << "not verified (--no-verify): the fitted prediction stands\n";
    }
    double pilot_seconds = 0;
    for (const TablePilot& p : pilots) pilot_seconds += p.pilot_seconds;
    std::cout << "plan time: pilots " << format_seconds(pilot_seconds) << ", verification "
              << format_seconds(verification ? verification->seconds : 0.0)
              << " (not part of the predicted generate time)\n";
    for (const PlacedAxis& r : st.placements)
        std::cout << "placed nodes '" << r.table << "' axis " << r.axis << ": " << r.count
                  << " explicit nodes, predicted max interpolation error " << sci(r.predicted_max)
                  << " (uniform in x: " << sci(r.uniform_max) << ", the axis' spacing: "
                  << sci(r.spacing_max) << ")"
                  << (r.predicted_max < r.spacing_max ? "" : "; not better, spacing kept") << "\n";
}

void run_plan(const PlanArgs& pa) {
    PlanState st;
    st.target = plan_target(pa);
    const Spec spec = parse_spec_file(pa.spec);
    st.indices = planned_tables(pa, spec);
    st.groups = recombined_groups(spec, st.indices);  // checked before the pilots
    const auto init_start = std::chrono::steady_clock::now();
    st.backend = pa.compute.make_backend();
    PilotOptions po;
    po.abs_floor = pa.abs_floor;
    // What a generate process pays before its first table (device set-up),
    // and its kernel start-up from PoCL's disk cache (host/plan/plan.h).
    po.process_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - init_start).count();
    po.fresh_backend = [&pa] { return pa.compute.make_backend(); };
    // Progress only for stages that last: a line every 2 s after the first 2 s.
    const PilotProgressFn progress = [&](const std::string& stage, const Progress& p) {
        if (pa.quiet || p.elapsed_seconds < 2 || p.elapsed_seconds - st.last_shown < 2) return;
        st.last_shown = p.elapsed_seconds;
        std::cerr << "plan: " << stage << ": " << static_cast<int>(100 * p.fraction) << "% "
                  << format_seconds(p.elapsed_seconds) << "\n";
    };
    for (std::size_t i : st.indices) {
        st.last_shown = 0;
        st.pilots.push_back(run_pilot(spec, i, *st.backend, po, progress));
    }
    // [[recombined]] terms share one node layout (docs/planning.md, "Recombined tables").
    st.all = make_recombined_candidates(st.pilots, st.target, st.groups);
    st.front = pareto_front(st.all);
    st.choice = choose_plan(st.front, st.target);
    st.measure = st.target.absolute ? "absolute" : "relative";
    if (pa.as_written) st.written = predict_as_written(spec, st.pilots, st.target, st.groups, st.written_why);
    // --place-nodes: explicit nodes equidistributing the pilot's error.
    place(pa, st);
    verify_plans(pa, spec, st);
    compare_adaptive(pa, spec, st);
    // A tensor plan above kLargePlanCells: the axis responsible, and the
    // adaptive representation as the way out (also on stderr under --json).
    if (st.choice)
        if (std::string w = large_plan_warning(st.placed ? *st.placed : st.front[*st.choice], st.pilots); !w.empty())
            st.warnings.push_back("choice: " + w);
    if (st.written)
        if (std::string w = large_plan_warning(*st.written, st.pilots); !w.empty())
            st.warnings.push_back("as written: " + w);
    if (pa.json)
        for (const std::string& w : st.warnings) std::cerr << "brdftab: warning: " << w << "\n";
    st.text = planned_output_text(pa, spec, st);
    if (pa.json)
        print_plan_json(pa, st);
    else
        print_plan_text(pa, st);
    if ((st.target.accuracy || st.target.budget) && !st.choice)
        throw Error(st.target.accuracy
                        ? "no candidate plan is predicted to reach a max total error of " +
                              sci(*st.target.accuracy) + " (smallest predicted: see the table)"
                        : "no candidate plan is predicted to finish within " + sci(*st.target.budget) + " s");
    if (!st.text.empty()) {
        AtomicOutput out(pa.output);
        {
            std::ofstream f(out.path());
            f << st.text;
            if (!f) throw Error("cannot write " + pa.output);
        }
        out.commit();
        if (!pa.json) std::cout << "wrote " << pa.output << "\n";
    }
}

}  // namespace

void register_plan(CLI::App& app) {
    auto* cmd = app.add_subcommand(
        "plan",
        "measure a spec's error terms and cost with short pilot runs, predict the error and time "
        "of candidate plans, and choose one for an accuracy target or a time budget");
    auto st = std::make_shared<PlanArgs>();
    cmd->add_option("SPEC", st->spec, "table specification (TOML)")->required();
    cmd->add_option("--accuracy", st->accuracy,
                    "choose the fastest plan whose predicted max total error <= E (relative, "
                    "with --abs-floor; absolute with --abs)");
    cmd->add_option("--budget", st->budget,
                    "choose the most accurate plan predicted to finish within SECONDS");
    cmd->add_flag("--abs", st->absolute, "errors are absolute (default: relative)");
    cmd->add_option("--abs-floor", st->abs_floor,
                    "relative errors divide by max(|value|, floor); default: 1e-3 x the largest "
                    "|value| the pilot saw (as `validate`)");
    cmd->add_option("--interpolation", st->interpolation,
                    "the interpolation the tables will be read with: linear (default) or cubic")
        ->check(CLI::IsMember({"linear", "cubic"}));
    cmd->add_option("--table", st->table, "plan this table only (default: every table)");
    cmd->add_option("-o,--output", st->output, "write the chosen plan as a spec")
        ->check(non_empty_path());
    cmd->add_flag("--json", st->json, "print pilots, Pareto plans and the choice as JSON");
    cmd->add_flag("--place-nodes", st->place_nodes,
                  "write explicit nodes that equidistribute the pilot's measured interpolation "
                  "error along each axis (linear interpolation; docs/planning.md)");
    cmd->add_flag("--as-written", st->as_written,
                  "also predict the spec's own plan (its node counts, method, samples or tolerance, "
                  "stored type) without choosing another; JSON key `as_written` (docs/planning.md)");
    cmd->add_flag("--no-verify", st->no_verify,
                  "do not verify the chosen (or --as-written) plan with a sparse certificate; keep the "
                  "fitted prediction (docs/planning.md \"Verified plans\")");
    cmd->add_option("--verify-limit", st->verify_limit,
                    "verify a table only when its certificate's probes touch at most this fraction of its "
                    "cells (default 0.25; 1: always); a table predicted to generate in <= 5 s is verified "
                    "whatever the fraction");
    cmd->add_option("--representation", st->representation,
                    "with --accuracy/--budget: tensor (the tensor plans only), adaptive or auto (also predict "
                    "the adaptive plan from pilot refinements and choose the one storing fewer values; "
                    "docs/adaptive.md). Default: the spec's [output] representation, else auto")
        ->check(CLI::IsMember({"tensor", "adaptive", "auto"}));
    cmd->add_flag("-q,--quiet", st->quiet, "no progress display");
    st->compute.add_to(*cmd, false);
    cmd->callback([st] { run_plan(*st); });
}

}  // namespace brdftab::cli
