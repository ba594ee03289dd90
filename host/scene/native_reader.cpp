// native_reader.cpp — brdftab's own material list (TOML), for models that no
// renderer's scene format has (Lambert-sphere particle albedo c, micrograin
// filling factor tau0 and stretches), or to name any brdftab model directly:
//
//   [[material]]
//   name = "dust"              # required, unique
//   model = "lambert-sphere"   # a brdftab model (brdftab models)
//   c = 0.95                   # its parameters and options, by brdftab name,
//                              # in brdftab units (angles in degrees)
#include <toml++/toml.h>

#include <set>
#include <sstream>

#include "host/core/error.h"
#include "host/scene/scene_internal.h"

namespace brdftab::scene_detail {
namespace {

std::string at(const std::string& file, const toml::source_region& r) {
    return file + ":" + std::to_string(r.begin.line) + ":" + std::to_string(r.begin.column);
}

}  // namespace

std::vector<SceneMaterial> read_native_materials(const std::string& path) {
    toml::table root;
    try {
        root = toml::parse_file(path);
    } catch (const toml::parse_error& e) {
        std::ostringstream msg;
        msg << path << ":" << e.source().begin.line << ":" << e.source().begin.column << ": "
            << e.description();
        throw InputError(msg.str());
    } catch (const std::exception& e) {
        throw InputError("cannot read material list '" + path + "': " + e.what());
    }
    for (const auto& [key, node] : root)
        if (key.str() != "material")
            throw InputError(at(path, node.source()) + ": key '" + std::string(key.str()) +
                             "': unknown; a material list has only [[material]] entries");
    const toml::array* list = root["material"].as_array();
    if (!list)
        throw InputError(path + ": no [[material]] entries (a brdftab material list needs at "
                                "least one)");
    std::vector<SceneMaterial> out;
    std::set<std::string> names;
    for (std::size_t k = 0; k < list->size(); ++k) {
        const toml::table* t = (*list)[k].as_table();
        const std::string prefix = "material[" + std::to_string(k) + "]";
        if (!t) throw InputError(at(path, (*list)[k].source()) + ": " + prefix + " is not a table");
        SceneMaterial m;
        m.format = "brdftab";
        m.where = at(path, t->source());
        m.type = "brdftab";
        for (const auto& [key_, node] : *t) {
            const std::string key(key_.str());
            const std::string where = at(path, node.source()) + ": key '" + prefix + "." + key + "'";
            if (key == "name" || key == "model") {
                const auto* s = node.as_string();
                if (!s || s->get().empty())
                    throw InputError(where + ": must be a non-empty string");
                (key == "name" ? m.name : m.native_model) = s->get();
                continue;
            }
            SceneParameter p;
            p.where = where;
            if (const auto* s = node.as_string()) {
                p.type = "string";
                p.texts.push_back(s->get());
            } else if (const auto* i = node.as_integer()) {
                p.type = "float";
                p.numbers.push_back(static_cast<double>(i->get()));
            } else if (const auto* f = node.as_floating_point()) {
                p.type = "float";
                p.numbers.push_back(f->get());
            } else {
                throw InputError(where + ": must be a number or a string");
            }
            m.parameters[key] = p;
        }
        if (m.name.empty()) throw InputError(m.where + ": " + prefix + " has no 'name'");
        if (m.native_model.empty())
            throw InputError(m.where + ": " + prefix + " ('" + m.name + "') has no 'model'");
        if (!names.insert(m.name).second)
            throw InputError(m.where + ": " + prefix + ": material name '" + m.name +
                             "' is used twice");
        out.push_back(std::move(m));
    }
    return out;
}

}  // namespace brdftab::scene_detail
