// kernel_sources.h — kernel sources embedded in the binary at build time.
//
// The build (cmake/EmbedKernels.cmake) stores every file under kernels/ in a
// generated translation unit.  load_kernel_source() resolves `#include "..."`
// directives recursively (relative to the including file, each file included
// once), emitting `#line N "kernels/<path>"` markers so compiler messages name
// the real file and line.  With a non-empty kernel_dir the files are read from
// disk instead (development: edit kernels without rebuilding).
#pragma once

#include <map>
#include <string>
#include <vector>

namespace brdftab {

// The name of the entry point estimate_kernel_source() generates.
constexpr const char* kEstimateKernelName = "bt_estimate";
// The two entry points sample_parallel_kernel_source() generates.
constexpr const char* kSampleKernelName = "bt_sample";
constexpr const char* kReduceKernelName = "bt_reduce";
constexpr const char* kRedoKernelName = "bt_sample_redo";
// The staged entry points (kernels/common/staged_samples.cl), in the same
// program when the quantity has staged samples.
constexpr const char* kStageKernelName = "bt_stage";
constexpr const char* kStageRedoKernelName = "bt_stage_redo";
constexpr const char* kStageRestKernelName = "bt_stage_rest";
// The three entry points node_parallel_kernel_source() generates.
constexpr const char* kNodePrepareKernelName = "bt_node_prepare";
constexpr const char* kNodeKernelName = "bt_node";
constexpr const char* kNodeSumKernelName = "bt_node_sum";
// The extra entry points of nested_node_parallel_kernel_source() (the group
// prepare and node-to-group kernels; the other three keep the names above).
constexpr const char* kNodeGroupKernelName = "bt_node_group";
constexpr const char* kNodeChunkKernelName = "bt_node_chunk";
constexpr const char* kNodeReduceKernelName = "bt_node_reduce";
constexpr const char* kNodeTableKernelName = "bt_node_table";
// The split-term node kernels (kernels/common/node_split.cl), in the flat
// program of a quantity whose terms are split.
constexpr const char* kNodeFirstKernelName = "bt_node_first";
constexpr const char* kNodeSecondKernelName = "bt_node_second";
// The entry point walk_parallel_kernel_source() generates.
constexpr const char* kWalkKernelName = "bt_estimate_walk";

std::vector<std::string> embedded_kernel_files();  // paths relative to kernels/
std::string load_kernel_source(const std::string& relative_path,
                               const std::string& kernel_dir = "");
// The complete program of a model: kernels/common/estimator.h, the model's
// kernel header (relative to kernels/), a generated prelude that binds the
// entry point's hook (bt_hook_sample = sample_function) and the entry point
// kernels/common/estimate.cl (bt_estimate).
std::string estimate_kernel_source(const std::string& kernel_header,
                                   const std::string& sample_function,
                                   const std::string& kernel_dir = "");
// The same program with the sample-parallel entry points instead
// (kernels/common/sample_parallel.cl: bt_sample, bt_reduce, bt_sample_redo):
// a separate program, so that the usual one keeps its source (and PoCL's
// cache entries) and its build time.  With stage_size > 0 the program also
// holds kernels/common/staged_samples.cl (bt_stage, bt_stage_redo,
// bt_stage_rest; hooks bound to stage_size, stage_function, rest_function).
std::string sample_parallel_kernel_source(const std::string& kernel_header,
                                          const std::string& sample_function,
                                          const std::string& kernel_dir = "",
                                          int stage_size = 0,
                                          const std::string& stage_function = "",
                                          const std::string& rest_function = "");
// The program of a quantity's node-parallel quadrature: the model's kernel
// header and the entry points of kernels/common/node_parallel.cl
// (bt_node_prepare, bt_node, bt_node_sum), their hooks bound to state_size
// and the model's node functions (QuantityInfo::node_parallel); a separate
// program, like the one above.  With both term_first and term_second named,
// it also holds kernels/common/node_split.cl (bt_node_first, bt_node_second).
std::string node_parallel_kernel_source(const std::string& kernel_header,
                                        const std::string& state_size,
                                        const std::string& count_function,
                                        const std::string& prepare_function,
                                        const std::string& term_function,
                                        const std::string& finish_function,
                                        const std::string& kernel_dir = "",
                                        const std::string& term_first = "",
                                        const std::string& term_second = "");
// The program of a quantity's nested node-parallel quadrature: the entry
// points of kernels/common/nested_node_parallel.cl (bt_node_table,
// bt_node_prepare, bt_node_group, bt_node_chunk, bt_node, bt_node_reduce,
// bt_node_sum), their hooks bound to the model's sizes and node functions
// (QuantityInfo::node_parallel, nested()).  An empty `table` names
// bt_node_no_table (node_parallel.h).
struct NestedNodeParallelNames {
    std::string table_entries, table_size, item_state_size, group_state_size, terms, partials,
        acc_size;
    std::string table, count, prepare, group_prepare, term, group_reduce, group_add, finish, sample;
};
std::string nested_node_parallel_kernel_source(const std::string& kernel_header,
                                               const NestedNodeParallelNames& names,
                                               const std::string& kernel_dir = "");
// The program of a random walk's walk-parallel launch: the model's kernel
// header and the entry point bt_estimate_walk of kernels/common/walk_parallel.cl,
// its hooks bound to the model's walk state and functions; a separate
// program, like the ones above.
struct WalkParallelNames {
    std::string state, setup, begin, step, value;
};
std::string walk_parallel_kernel_source(const std::string& kernel_header, const WalkParallelNames& names,
                                        const std::string& kernel_dir = "");
// The -D definitions that specialise the program of estimate_kernel_source()
// to one quantity, option set, method (BT_METHOD_*) and point stride
// (kernels/common/estimator.h, "Specialisation"), with a leading space:
// " -D BT_SPEC_QUANTITY=2 -D BT_SPEC_METHOD=1 -D BT_SPEC_OPTIONS=0,1 -D BT_SPEC_STRIDE=6".
std::string specialisation_options(int quantity, const std::vector<int>& options,
                                   unsigned method, std::size_t stride);

// Adds kernel files (path relative to kernels/ -> text) to the embedded set,
// for models compiled outside kernels/ (the test-only toy model: see
// docs/adding-a-model.md).  Existing paths are kept.  Returns true, so that a
// static initialiser can call it.
bool add_embedded_kernel_sources(const std::map<std::string, std::string>& files);

}  // namespace brdftab
