// kernel_sources.cpp — include resolution over the embedded kernel table (or a
// kernel directory on disk), producing one self-contained OpenCL C source.
//
// Why textual inclusion instead of clCompileProgram with a header list: PoCL
// never caches programs built from in-memory headers, and `-I` cannot carry
// paths with spaces (docs/contributing.md).  One flat source with `#line`
// markers builds from PoCL's cache and still reports errors against the real
// file and line.
#include "host/engine/kernel_sources.h"

#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <sys/stat.h>

#include "host/core/error.h"

namespace brdftab {
namespace detail {
// Defined in the generated build/generated/embedded_kernels.cpp
// (cmake/EmbedKernelsScript.cmake); key = path relative to kernels/.
const std::map<std::string, std::string>& embedded_kernel_map();
}  // namespace detail

namespace {

// Kernel files added at run time (add_embedded_kernel_sources).
std::map<std::string, std::string>& added_kernel_map() {
    static std::map<std::string, std::string> files;
    return files;
}

const std::string* embedded_file(const std::string& rel) {
    const auto& built_in = detail::embedded_kernel_map();
    auto it = built_in.find(rel);
    if (it != built_in.end()) return &it->second;
    auto added = added_kernel_map().find(rel);
    return added == added_kernel_map().end() ? nullptr : &added->second;
}

// Lexically normalise a '/'-separated relative path: drop "." and empty
// components, resolve "..".  Returns false when the path is absolute or
// climbs above the kernel root, so such an include can never name a file
// outside kernels/.
bool normalise(const std::string& path, std::string& out) {
    if (path.empty() || path[0] == '/') return false;
    std::vector<std::string> parts;
    std::size_t start = 0;
    while (start <= path.size()) {
        std::size_t slash = path.find('/', start);
        if (slash == std::string::npos) slash = path.size();
        std::string part = path.substr(start, slash - start);
        start = slash + 1;
        if (part.empty() || part == ".") continue;
        if (part == "..") {
            if (parts.empty()) return false;
            parts.pop_back();
        } else {
            parts.push_back(part);
        }
    }
    if (parts.empty()) return false;
    out.clear();
    for (std::size_t i = 0; i < parts.size(); ++i) {
        if (i) out += '/';
        out += parts[i];
    }
    return true;
}

std::string directory_of(const std::string& path) {
    std::size_t slash = path.rfind('/');
    return slash == std::string::npos ? std::string() : path.substr(0, slash + 1);
}

bool is_regular_file(const std::string& path) {
    struct stat st;
    return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

bool is_directory(const std::string& path) {
    struct stat st;
    return ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

// Where kernel files come from: the embedded table or a directory.
class SourceStore {
public:
    explicit SourceStore(const std::string& kernel_dir) : dir_(kernel_dir) {
        if (!dir_.empty() && dir_.back() != '/') dir_ += '/';
    }
    bool from_disk() const { return !dir_.empty(); }
    const std::string& dir() const { return dir_; }

    bool exists(const std::string& rel) const {
        if (!from_disk()) return embedded_file(rel) != nullptr;
        return is_regular_file(dir_ + rel);
    }

    std::string read(const std::string& rel) const {
        if (!from_disk()) return *embedded_file(rel);
        std::ifstream in(dir_ + rel, std::ios::binary);
        if (!in) throw InputError("cannot read kernel file '" + dir_ + rel + "'");
        std::ostringstream ss;
        ss << in.rdbuf();
        return ss.str();
    }

private:
    std::string dir_;
};

// If `line` is a `#include "name"` directive, store name and return true.
// Angle-bracket includes and anything else return false (left untouched).
bool parse_quoted_include(const std::string& line, std::string& name) {
    std::size_t i = 0, n = line.size();
    auto skip_blank = [&] {
        while (i < n && (line[i] == ' ' || line[i] == '\t')) ++i;
    };
    skip_blank();
    if (i >= n || line[i] != '#') return false;
    ++i;
    skip_blank();
    if (line.compare(i, 7, "include") != 0) return false;
    i += 7;
    skip_blank();
    if (i >= n || line[i] != '"') return false;
    std::size_t close = line.find('"', i + 1);
    if (close == std::string::npos) return false;
    name = line.substr(i + 1, close - i - 1);
    return !name.empty();
}

std::string line_marker(std::size_t line, const std::string& rel) {
    return "#line " + std::to_string(line) + " \"kernels/" + rel + "\"\n";
}

// Appends `rel` (already normalised and known to exist) to `out`, inlining
// its quoted includes depth-first.  `seen` holds every file already emitted:
// a second include of the same file becomes a comment, which keeps the line
// count (so no marker is needed) and stops include cycles.
// Limitation: an include inside `#if 0` or a block comment is still inlined
// here; our kernels do not do that.
void expand(const SourceStore& store, const std::string& rel, std::set<std::string>& seen,
            std::string& out) {
    seen.insert(rel);
    out += line_marker(1, rel);
    const std::string text = store.read(rel);
    std::size_t pos = 0, line_no = 0;
    while (pos < text.size()) {
        std::size_t eol = text.find('\n', pos);
        const bool has_newline = eol != std::string::npos;
        if (!has_newline) eol = text.size();
        std::string line = text.substr(pos, eol - pos);
        pos = eol + 1;
        ++line_no;

        std::string stripped = line;
        if (!stripped.empty() && stripped.back() == '\r') stripped.pop_back();
        std::string name;
        if (!parse_quoted_include(stripped, name)) {
            out += line;
            out += '\n';
            continue;
        }
        // Relative to the including file first, then to the kernel root —
        // the same order a C preprocessor uses for quoted includes with
        // -I kernels/.
        std::string target, candidate;
        if (normalise(directory_of(rel) + name, candidate) && store.exists(candidate)) {
            target = candidate;
        } else if (normalise(name, candidate) && store.exists(candidate)) {
            target = candidate;
        }
        if (target.empty()) {
            std::string where = store.from_disk() ? "in kernel directory '" + store.dir() + "'"
                                                  : "among the embedded kernel sources";
            std::string msg = "kernels/" + rel + ":" + std::to_string(line_no) +
                              ": included file \"" + name + "\" not found " + where;
            if (store.from_disk()) throw InputError(msg);
            throw Error(msg);
        }
        if (seen.count(target)) {
            out += "/* #include \"" + name + "\": already included */\n";
            continue;
        }
        expand(store, target, seen, out);
        if (!out.empty() && out.back() != '\n') out += '\n';
        out += line_marker(line_no + 1, rel);
    }
}

}  // namespace

std::vector<std::string> embedded_kernel_files() {
    std::vector<std::string> files;
    for (const auto& entry : detail::embedded_kernel_map()) files.push_back(entry.first);
    for (const auto& entry : added_kernel_map())
        if (!detail::embedded_kernel_map().count(entry.first)) files.push_back(entry.first);
    return files;
}

bool add_embedded_kernel_sources(const std::map<std::string, std::string>& files) {
    for (const auto& [path, text] : files) added_kernel_map().emplace(path, text);
    return true;
}

namespace {

// One hook binding of a template (kernels/common/*.cl): `#define hook value`.
std::string bind(const std::string& hook, const std::string& value) {
    return "#define " + hook + " " + value + "\n";
}

// The generated prelude's marker, so that compiler messages in the hook
// bindings name them.
std::string hooks_marker(const std::string& what, const std::string& kernel_header) {
    return "#line 1 \"generated " + what + " hooks for " + kernel_header + "\"\n";
}

}  // namespace

std::string estimate_kernel_source(const std::string& kernel_header,
                                   const std::string& sample_function,
                                   const std::string& kernel_dir) {
    // The entry point is kernels/common/estimate.cl for every model; the
    // prelude binds its hook to the model's sample function.
    std::string source = load_kernel_source("common/estimator.h", kernel_dir);
    source += load_kernel_source(kernel_header, kernel_dir);
    source += hooks_marker("estimate", kernel_header);
    source += bind("bt_hook_sample", sample_function);
    source += load_kernel_source("common/estimate.cl", kernel_dir);
    return source;
}

std::string sample_parallel_kernel_source(const std::string& kernel_header,
                                          const std::string& sample_function,
                                          const std::string& kernel_dir, int stage_size,
                                          const std::string& stage_function,
                                          const std::string& rest_function) {
    // One sample per work item: kernels/common/sobol.h picks its form for that.
    std::string source = "#define BT_SAMPLE_PARALLEL_PROGRAM 1\n";
    source += load_kernel_source("common/estimator.h", kernel_dir);
    source += load_kernel_source(kernel_header, kernel_dir);
    source += hooks_marker("sample-parallel", kernel_header);
    source += bind("bt_hook_sample", sample_function);
    if (stage_size > 0) {
        source += bind("BT_HOOK_STAGE_SIZE", std::to_string(stage_size));
        source += bind("bt_hook_stage", stage_function);
        source += bind("bt_hook_rest", rest_function);
    }
    source += load_kernel_source("common/sample_parallel.cl", kernel_dir);
    if (stage_size > 0) source += load_kernel_source("common/staged_samples.cl", kernel_dir);
    return source;
}

namespace {
// The start of the node-parallel and walk-parallel programs: forced inlining
// unless the build options decide (a call left in the node kernel or in the
// walk's round keeps its work-item loop scalar, as measured on the walk-parallel
// quantities, docs/benchmarks.md), the estimator, the model's
// header and the launch's header (`launch_header`, relative to kernels/).
std::string forced_inline_prologue(const std::string& kernel_header, const std::string& launch_header,
                                   const std::string& kernel_dir) {
    std::string source = "#if !defined(BT_FORCE_INLINE)\n#define BT_FORCE_INLINE 1\n#endif\n";
    source += load_kernel_source("common/estimator.h", kernel_dir);
    source += load_kernel_source(kernel_header, kernel_dir);
    source += load_kernel_source(launch_header, kernel_dir);
    return source;
}
}  // namespace

std::string walk_parallel_kernel_source(const std::string& kernel_header, const WalkParallelNames& names,
                                        const std::string& kernel_dir) {
    std::string source = forced_inline_prologue(kernel_header, "common/walk_parallel.h", kernel_dir);
    source += hooks_marker("walk-parallel", kernel_header);
    source += bind("bt_hook_walk_state", names.state);
    source += bind("bt_hook_walk_setup", names.setup);
    source += bind("bt_hook_walk_begin", names.begin);
    source += bind("bt_hook_walk_step", names.step);
    source += bind("bt_hook_walk_value", names.value);
    source += load_kernel_source("common/walk_parallel.cl", kernel_dir);
    return source;
}

std::string node_parallel_kernel_source(const std::string& kernel_header,
                                        const std::string& state_size,
                                        const std::string& count_function,
                                        const std::string& prepare_function,
                                        const std::string& term_function,
                                        const std::string& finish_function,
                                        const std::string& kernel_dir,
                                        const std::string& term_first,
                                        const std::string& term_second) {
    std::string source = forced_inline_prologue(kernel_header, "common/node_parallel.h", kernel_dir);
    const bool split = !term_first.empty() && !term_second.empty();
    source += hooks_marker("node-parallel", kernel_header);
    source += bind("BT_HOOK_STATE_SIZE", "(" + state_size + ")");
    source += bind("bt_hook_count", count_function);
    source += bind("bt_hook_prepare", prepare_function);
    source += bind("bt_hook_term", term_function);
    source += bind("bt_hook_finish", finish_function);
    if (split) {
        source += bind("bt_hook_term_first", term_first);
        source += bind("bt_hook_term_second", term_second);
    }
    source += load_kernel_source("common/node_parallel.cl", kernel_dir);
    if (split) source += load_kernel_source("common/node_split.cl", kernel_dir);
    return source;
}

std::string nested_node_parallel_kernel_source(const std::string& kernel_header,
                                               const NestedNodeParallelNames& f,
                                               const std::string& kernel_dir) {
    std::string source = forced_inline_prologue(kernel_header, "common/node_parallel.h", kernel_dir);
    source += hooks_marker("nested node-parallel", kernel_header);
    source += bind("BT_HOOK_TABLE_ENTRIES", "(" + f.table_entries + ")");
    source += bind("BT_HOOK_TABLE_SIZE", "(" + f.table_size + ")");
    source += bind("BT_HOOK_ITEM_STATE_SIZE", "(" + f.item_state_size + ")");
    source += bind("BT_HOOK_GROUP_STATE_SIZE", "(" + f.group_state_size + ")");
    source += bind("BT_HOOK_TERMS", "(" + f.terms + ")");
    source += bind("BT_HOOK_PARTIALS", "(" + f.partials + ")");
    source += bind("BT_HOOK_ACC_SIZE", "(" + f.acc_size + ")");
    source += bind("bt_hook_table", f.table.empty() ? "bt_node_no_table" : f.table);
    source += bind("bt_hook_count", f.count);
    source += bind("bt_hook_prepare", f.prepare);
    source += bind("bt_hook_group_prepare", f.group_prepare);
    source += bind("bt_hook_term_setup", f.term + "_setup");
    source += bind("bt_hook_term", f.term);
    source += bind("bt_hook_group_reduce", f.group_reduce);
    source += bind("bt_hook_group_add", f.group_add);
    source += bind("bt_hook_finish", f.finish);
    source += bind("bt_hook_sample", f.sample);
    source += load_kernel_source("common/nested_node_parallel.cl", kernel_dir);
    return source;
}

std::string specialisation_options(int quantity, const std::vector<int>& options,
                                   unsigned method, std::size_t stride) {
    std::string list;
    for (int o : options) list += (list.empty() ? "" : ",") + std::to_string(o);
    if (list.empty()) list = "0";  // an array initialiser needs one element
    return " -D BT_SPEC_QUANTITY=" + std::to_string(quantity) +
           " -D BT_SPEC_METHOD=" + std::to_string(method) + " -D BT_SPEC_OPTIONS=" + list +
           " -D BT_SPEC_STRIDE=" + std::to_string(stride);
}

std::string load_kernel_source(const std::string& relative_path, const std::string& kernel_dir) {
    SourceStore store(kernel_dir);
    if (store.from_disk() && !is_directory(kernel_dir))
        throw InputError("kernel directory '" + kernel_dir + "' does not exist");
    std::string rel;
    if (!normalise(relative_path, rel) || !store.exists(rel)) {
        if (store.from_disk())
            throw InputError("kernel file '" + relative_path + "' not found in kernel directory '" +
                             kernel_dir + "'");
        throw Error("kernel file '" + relative_path + "' is not among the embedded kernel sources");
    }
    std::set<std::string> seen;
    std::string out;
    expand(store, rel, seen, out);
    return out;
}

}  // namespace brdftab
