// resources.cpp — the OpenCL resources every launch strategy shares
// (resources.h), and the order in which the backend asks the strategies.
#include "host/engine/launch/resources.h"

#include <algorithm>
#include <mutex>
#include <new>
#if defined(__linux__)
#include <dlfcn.h>
#include <link.h>
#endif

#include "kernels/common/estimator.h"
#include "host/engine/kernel_sources.h"

namespace brdftab::launch {

EntryRuns runs_within(const std::vector<std::uint32_t>& offset, std::size_t count, std::size_t cap) {
    EntryRuns out;
    for (std::size_t first = 0; first < count;) {
        std::size_t last = first + 1;
        while (last < count && offset[last + 1] - offset[first] <= cap) ++last;
        out.runs.emplace_back(first, last);
        out.most_size = std::max<std::size_t>(out.most_size, offset[last] - offset[first]);
        out.most_entries = std::max(out.most_entries, last - first);
        first = last;
    }
    return out;
}

const QuantityInfo* launch_quantity(const BatchLaunch& l) {
    for (const QuantityInfo& q : l.model->quantities)
        if (q.id == l.quantity) return &q;
    return nullptr;
}

bool option_is(const ModelInfo& model, const std::vector<int>& options, const std::string& name,
               const std::string& choice) {
    const OptionInfo* o = model.find_option(name);
    if (!o) return false;
    const std::size_t k = static_cast<std::size_t>(o - model.options.data());
    return k < options.size() && options[k] == o->index_of(choice);
}

void options_array(const BatchLaunch& l, int* opts) {
    std::fill_n(opts, BT_MAX_OPTIONS, 0);
    std::copy_n(l.options.begin(), std::min<std::size_t>(l.options.size(), BT_MAX_OPTIONS), opts);
}

void grow_buffer(cl::Context& ctx, cl::Buffer& buffer, std::size_t& have, std::size_t need,
                 cl_mem_flags flags) {
    need = std::max<std::size_t>(need, 1);
    if (need <= have) return;
    have = std::max(need, 2 * have);
    buffer = cl::Buffer(ctx, flags, have);
}

HostMemory::HostMemory(std::size_t bytes) {
    constexpr std::size_t kPage = 4096;
    const std::size_t rounded = std::max<std::size_t>(kPage, (bytes + kPage - 1) / kPage * kPage);
    data_.reset(std::aligned_alloc(kPage, rounded));
    if (!data_) throw std::bad_alloc();
}

LaunchResources::LaunchResources(const DeviceInfo& device, Precision precision_,
                                 std::string kernel_dir_, const EngineTuning& tuning_)
    : runtime(device), precision(precision_), kernel_dir(std::move(kernel_dir_)), tuning(tuning_) {}

void LaunchResources::swap_buffer_sets() {
    std::swap(staged, idle_.staged);
    std::swap(points, idle_.points);
    std::swap(cells, idle_.cells);
    std::swap(batches, idle_.batches);
    std::swap(out_mean, idle_.out_mean);
    std::swap(out_m2, idle_.out_m2);
    std::swap(buffer_items_, idle_.items);
    std::swap(buffer_point_bytes_, idle_.point_bytes);
    std::swap(buffer_accum_size_, idle_.accum_size);
}

void LaunchResources::reserve_buffers(std::size_t items, std::size_t point_bytes,
                                      std::size_t accum) {
    cl::Context& ctx = runtime.context();
    if (items > buffer_items_ || accum != buffer_accum_size_) {
        // Grow geometrically, so that launches that grow step by step
        // (estimate(): at most 4x per launch) reallocate a few times only.
        const std::size_t want = std::max(items, 2 * buffer_items_);
        cells = cl::Buffer(ctx, CL_MEM_READ_ONLY, want * sizeof(std::uint32_t));
        batches = cl::Buffer(ctx, CL_MEM_READ_ONLY, want * sizeof(std::uint32_t));
        out_mean = cl::Buffer(ctx, CL_MEM_WRITE_ONLY, want * accum);
        out_m2 = cl::Buffer(ctx, CL_MEM_WRITE_ONLY, want * accum);
        buffer_items_ = want;
        buffer_accum_size_ = accum;
    }
    if (point_bytes > buffer_point_bytes_) {
        const std::size_t want = std::max(point_bytes, 2 * buffer_point_bytes_);
        points = cl::Buffer(ctx, CL_MEM_READ_ONLY, want);
        buffer_point_bytes_ = want;
    }
    if (!options()) {
        options = cl::Buffer(ctx, CL_MEM_READ_ONLY, BT_MAX_OPTIONS * sizeof(int));
        options_known = false;
    }
}

void LaunchResources::reserve_staged(StagedInputs& target, std::size_t items,
                                     std::size_t point_doubles) {
    if (items <= target.items && point_doubles <= target.point_doubles) return;
    // Grown geometrically as launches grow.
    cl::Context& ctx = runtime.context();
    const std::size_t want_items = std::max(items, 2 * target.items);
    const std::size_t want_doubles = std::max(point_doubles, 2 * target.point_doubles);
    target.points = target.cells = target.batches = cl::Buffer();
    target = StagedInputs{};
    target.points_host = HostMemory(want_doubles * sizeof(double));
    target.cells_host = HostMemory(want_items * sizeof(std::uint32_t));
    target.batches_host = HostMemory(want_items * sizeof(std::uint32_t));
    const cl_mem_flags flags = CL_MEM_READ_ONLY | CL_MEM_USE_HOST_PTR;
    target.points = cl::Buffer(ctx, flags, want_doubles * sizeof(double), target.points_host.get());
    target.cells = cl::Buffer(ctx, flags, want_items * sizeof(std::uint32_t), target.cells_host.get());
    target.batches =
        cl::Buffer(ctx, flags, want_items * sizeof(std::uint32_t), target.batches_host.get());
    target.items = want_items;
    target.point_doubles = want_doubles;
}

namespace {

#if defined(__linux__)
// Sets one LLVM command-line option in every LLVM library loaded in this
// process (PoCL links libLLVM-N.so and compiles in the calling process);
// true if one took it.  LLVM's C entry point, so no LLVM headers are needed;
// it reports a bad option to llvm::nulls() and does not exit.
bool set_loaded_llvm_option(const char* option) {
    std::vector<std::string> libraries;
    dl_iterate_phdr(
        [](struct dl_phdr_info* info, std::size_t, void* data) {
            const std::string name = info->dlpi_name ? info->dlpi_name : "";
            if (name.find("/libLLVM") != std::string::npos)
                static_cast<std::vector<std::string>*>(data)->push_back(name);
            return 0;
        },
        &libraries);
    bool set = false;
    for (const std::string& name : libraries) {
        void* library = dlopen(name.c_str(), RTLD_LAZY | RTLD_NOLOAD);
        if (!library) continue;
        using ParseOptions = void (*)(int, const char* const*, const char*);
        auto parse = reinterpret_cast<ParseOptions>(dlsym(library, "LLVMParseCommandLineOptions"));
        if (parse) {
            const char* argv[] = {"brdftab", option};
            parse(2, argv, "");
            set = true;
        }
        dlclose(library);
    }
    return set;
}
#else
bool set_loaded_llvm_option(const char*) { return false; }
#endif

// Turns clang's SLP vectoriser off in PoCL's LLVM, once per process; true if
// it is off.  PoCL runs it on each work item before it builds the work-item
// loops, and the 2-wide vectors it packs make the loop vectoriser refuse those
// loops ("instruction return type cannot be vectorized"); which pairs it packs
// depends on the target's cost model (BT_SLP_SPLIT in kernels/common/compat.h
// splits the ones skylake-avx512 packs, not those of haswell).  PoCL accepts
// neither -fno-slp-vectorize nor -mllvm as build options, but its LLVM reads
// LLVM's own options, process-wide: a threshold no tree reaches keeps SLP
// from vectorising anything.  Kernels keep their values (SLP reorders no
// arithmetic); docs/contributing.md, "What keeps PoCL's work-item loop scalar".
bool pocl_slp_off(const DeviceInfo& device) {
    if (device.platform_name.find("Portable Computing Language") == std::string::npos) return false;
    static std::once_flag once;
    static bool off = false;
    std::call_once(once, [] { off = set_loaded_llvm_option("-slp-threshold=1000000000"); });
    return off;
}

}  // namespace

std::string LaunchResources::build_options(const BatchLaunch& l) const {
    std::string out = "-cl-std=CL1.2";
    out += runtime.device_info().has_fp64 ? " -D BT_HAS_FP64=1" : " -D BT_HAS_FP64=0";
    if (precision == Precision::Float) out += " -D BT_REAL_IS_FLOAT=1";
    // tuning.extra_kernel_options: extra build options, for experiments
    // (e.g. "-D BT_SAMPLE_BARRIER=0").
    const std::string extra =
        tuning.extra_kernel_options.empty() ? std::string() : " " + tuning.extra_kernel_options;
    out += specialisation_options(l.quantity, l.options, l.method, l.stride);
    // Forced inlining (kernels/common/estimator.h) where the model asks for
    // it (ModelInfo::force_inline, measured there); extra kernel options
    // naming BT_FORCE_INLINE decide instead.
    if (extra.find("BT_FORCE_INLINE") == std::string::npos && l.model->force_inline)
        out += " -D BT_FORCE_INLINE=1";
    // PoCL's SLP vectoriser off (pocl_slp_off), unless extra kernel options
    // name BT_POCL_SLP (scripts/slp-pairs.sh sets BT_POCL_SLP=1 to see its
    // packs).  The define names the setting for PoCL's program cache, whose
    // key has the build options but not LLVM's.
    if (extra.find("BT_POCL_SLP") == std::string::npos && pocl_slp_off(runtime.device_info()))
        out += " -D BT_POCL_SLP=0";
    out += extra;
    return out;
}

// Built programs of this process, keyed by context, build options and source.
// A program holds a reference to its context, so a context's handle cannot be
// reused for another one while an entry names it.  PoCL's disk cache still
// makes the first build in a new process cheap.
cl::Program LaunchResources::program(const std::string& source, const std::string& options_text) {
    static std::mutex mutex;
    static std::map<std::string, cl::Program> programs;
    const std::string key = std::to_string(reinterpret_cast<std::uintptr_t>(runtime.context()())) +
                            "\n" + options_text + "\n" + source;
    std::lock_guard<std::mutex> lock(mutex);
    auto it = programs.find(key);
    if (it != programs.end()) return it->second;
    cl::Program built = runtime.build_program(source, options_text);
    programs.emplace(key, built);
    return built;
}

OpenCLError LaunchResources::entry_point_error(const cl::Error& e, const std::string& what,
                                               const ModelInfo& model) {
    return OpenCLError(e.what(), e.err(),
                       what + " of model '" + model.name + "' (kernels/" + model.kernel_header + ")");
}

std::size_t LaunchResources::local_group() const {
    const std::size_t chosen = tuning.local_size;
    if (chosen == 0 || chosen >= 256 || 256 % chosen != 0 ||
        chosen > runtime.device_info().max_work_group_size)
        return 256;  // the driver's choice (PoCL: within a multiple of 256)
    return chosen;
}

std::size_t LaunchResources::padded_global(std::size_t items) const {
    const std::size_t group = local_group();
    return (items + group - 1) / group * group;
}

cl::NDRange LaunchResources::local_range() const {
    const std::size_t group = local_group();
    return group == 256 ? cl::NullRange : cl::NDRange(group);
}

int LaunchResources::set_work_args(cl::Kernel& kernel, const BatchLaunch& l) {
    int a = 0;
    kernel.setArg(a++, l.staged ? staged.points : points);
    kernel.setArg(a++, static_cast<cl_uint>(l.stride));
    kernel.setArg(a++, options);
    kernel.setArg(a++, static_cast<cl_uint>(l.options.size()));
    kernel.setArg(a++, static_cast<cl_int>(l.quantity));
    kernel.setArg(a++, static_cast<cl_uint>(l.method));
    kernel.setArg(a++, static_cast<cl_uint>(l.key0));
    kernel.setArg(a++, static_cast<cl_uint>(l.key1));
    kernel.setArg(a++, l.staged ? staged.cells : cells);
    kernel.setArg(a++, l.staged ? staged.batches : batches);
    return a;
}

void LaunchResources::set_option_args(cl::Kernel& kernel, const BatchLaunch& l) {
    kernel.setArg(0, options);
    kernel.setArg(1, static_cast<cl_uint>(l.options.size()));
    kernel.setArg(2, static_cast<cl_int>(l.quantity));
}

std::vector<std::unique_ptr<LaunchStrategy>> make_launch_strategies(LaunchResources& r) {
    // Sample-parallel before walk-parallel (EngineTuning::sample_parallel On
    // forces it for a walk too); the node-parallel ones take quadratures
    // only, the others Monte Carlo / RQMC; the usual kernel takes any launch.
    std::vector<std::unique_ptr<LaunchStrategy>> out;
    auto samples = make_sample_parallel_common(r);
    out.push_back(make_staged_launch(r, samples));
    out.push_back(make_sample_parallel_launch(r, samples));
    auto nodes = make_node_parallel_common(r);
    out.push_back(make_nested_node_launch(r, nodes));
    out.push_back(make_split_node_launch(r, nodes));
    out.push_back(make_flat_node_launch(r, nodes));
    out.push_back(make_walk_parallel_launch(r));
    out.push_back(make_usual_launch(r));
    return out;
}

}  // namespace brdftab::launch
