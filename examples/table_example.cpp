// table_example.cpp — a renderer-side consumer of brdftab tables.
//
//   table_example FILE.h5 [TABLE] [name=value ...]
//
// Opens one table (default: the first in the file), prints its axes and
// metadata, a few interpolated values, and — for isotropic BRDF tables with
// theta_i/theta_o(/phi_d) axes — a few importance samples (other tables,
// such as albedos, skip that part).  Parameters not
// given on the command line are set to the middle of their axis (or of the
// recombination range).
#include <brdftab/core/error.h>
#include <brdftab/lookup/lookup.h>
#include <brdftab/io/table_io.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <random>
#include <string>
#include <vector>

using namespace brdftab;

int main(int argc, char** argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: %s FILE.h5 [TABLE] [name=value ...]\n", argv[0]);
        return 2;
    }
    try {
        const std::string path = argv[1];
        std::string name;
        std::map<std::string, double> given;
        for (int a = 2; a < argc; ++a) {
            const std::string arg = argv[a];
            const auto eq = arg.find('=');
            if (eq == std::string::npos)
                name = arg;
            else
                given[arg.substr(0, eq)] = std::strtod(arg.c_str() + eq + 1, nullptr);
        }
        if (name.empty()) {
            const auto names = list_tables(path);
            if (names.empty()) throw InputError(path + ": no tables");
            name = names.front();
        }
        const LookupTable lt = LookupTable::open(path, name);
        std::printf("table %s: model %s, quantity %s, units %s\n", name.c_str(),
                    lt.model().c_str(), lt.quantity().c_str(), lt.units().c_str());
        std::printf("method %s, device %s, brdftab %s\n", method_attribute(lt.table()).c_str(),
                    lt.table().device.c_str(), lt.table().version.c_str());
        for (const auto& a : lt.axes())
            std::printf("  axis %-8s [%g, %g] %s, %zu nodes, %s spacing\n", a.name.c_str(),
                        a.min, a.max, a.unit.c_str(), a.count, spacing_name(a.spacing));
        std::printf("parameters %s\n", lt.parameters().dump().c_str());

        // Values at the centre of the table and at its first node.
        std::vector<double> mid, first;
        for (const auto& a : lt.axes()) {
            mid.push_back(0.5 * (a.min + a.max));
            first.push_back(a.min);
        }
        std::map<std::string, double> params;
        if (lt.has_recombination()) {
            const std::string p = lt.coordinate_names().back();
            const auto& r = lt.parameters()["recombine"];
            double v = r.contains("range") ? 0.5 * (r["range"][0].get<double>() +
                                                    r["range"][1].get<double>())
                                           : 0.5;
            if (given.count(p)) v = given[p];
            mid.push_back(v);
            first.push_back(v);
            params[p] = v;
        }
        std::printf("value at axis midpoints: linear %g, cubic %g\n", lt.eval(mid),
                    lt.eval(mid, Interpolation::Cubic));
        std::printf("value at first node: %g\n", lt.eval(first));

        // Direction-level use needs an incident and an outgoing angle axis
        // and no azimuth of its own (isotropic); an albedo table over
        // theta_i, say, has nothing to sample.
        bool has_in = false, has_out = false, anisotropic = false;
        for (const auto& a : lt.axes()) {
            has_in = has_in || a.name == "theta_i" || a.name == "mu_i";
            has_out = has_out || a.name == "theta_o" || a.name == "mu_o";
            anisotropic = anisotropic || a.name == "phi_i" || a.name == "phi_o";
        }
        if (!has_in || !has_out || anisotropic) {
            std::printf("no direction-level evaluation or sampling: the table is not an "
                        "isotropic function of (wi, wo)\n");
            return 0;
        }

        // Direction-level use: bind the non-angle parameters, then evaluate
        // and sample as a renderer would.
        BoundTable bound = [&] {
            for (const auto& a : lt.axes()) {
                if (a.name == "theta_i" || a.name == "theta_o" || a.name == "mu_i" ||
                    a.name == "mu_o" || a.name == "phi_d")
                    continue;
                params[a.name] = given.count(a.name) ? given[a.name] : 0.5 * (a.min + a.max);
            }
            return lt.bind(params);
        }();
        const double ti = 40 * 3.14159265358979 / 180;
        const Vec3 wi{std::sin(ti), 0, std::cos(ti)};
        std::printf("f(theta_i=40, theta_o=40, phi_d=180) = %g\n",
                    bound.eval(wi, Vec3{-wi.x, 0, wi.z}));
        if (!bound.can_sample()) {
            std::printf("no sampling: %s\n", bound.sampling_error().c_str());
            return 0;
        }
        std::mt19937_64 rng(1);
        std::uniform_real_distribution<double> u(0, 1);
        double sum = 0;
        const int n = 100000;
        for (int k = 0; k < n; ++k) {
            const SampleResult s = bound.sample(wi, u(rng), u(rng));
            if (k < 5)
                std::printf("  sample wo = (%.4f, %.4f, %.4f)  pdf %.5g  f %.5g  weight %.5g\n",
                            s.wo.x, s.wo.y, s.wo.z, s.pdf, s.value, s.weight);
            sum += s.weight;
        }
        std::printf("directional albedo at theta_i = 40 (mean weight of %d samples): %g\n", n,
                    sum / n);
        return 0;
    } catch (const InputError& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 2;
    } catch (const Error& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    }
}
