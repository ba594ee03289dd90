// mitsuba_reader.cpp — the BSDFs of a Mitsuba 3 (or 0.6) XML scene.
//
// Read with pugixml.  Interpreted: <default name value/> and $name
// substitution, <include filename/>, <bsdf> at scene level (named by id,
// used when a shape refers to it with <ref id/>) and inside <shape>, the
// wrapper BSDFs (twosided, mask, bumpmap, normalmap: the material is the
// BSDF they wrap, named by the wrapper's id), blendbsdf (listed, with its
// parts), and the parameter elements float, integer, boolean, string, rgb,
// spectrum and texture (bitmap textures become value ranges).  Mitsuba 0.6
// camelCase names (intIOR, diffuseReflectance) are read as their Mitsuba 3
// snake_case equivalents.
#include <pugixml.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>

#include "host/core/error.h"
#include "host/scene/scene_internal.h"

namespace brdftab::scene_detail {
namespace {

const std::set<std::string> kWrappers = {"twosided", "mask", "bumpmap", "normalmap"};

// intIOR -> int_ior, diffuseReflectance -> diffuse_reflectance, alphaU -> alpha_u.
std::string snake_case(const std::string& name) {
    std::string out;
    for (std::size_t i = 0; i < name.size(); ++i) {
        const char c = name[i];
        if (std::isupper(static_cast<unsigned char>(c))) {
            if (i > 0 && (std::islower(static_cast<unsigned char>(name[i - 1])) ||
                          std::isdigit(static_cast<unsigned char>(name[i - 1]))))
                out += '_';
            out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        } else {
            out += c;
        }
    }
    return out;
}

std::vector<double> parse_numbers(const std::string& text, bool& ok) {
    std::vector<double> out;
    std::string cleaned = text;
    std::replace(cleaned.begin(), cleaned.end(), ',', ' ');
    std::istringstream in(cleaned);
    std::string word;
    ok = true;
    while (in >> word) {
        char* end = nullptr;
        const double v = std::strtod(word.c_str(), &end);
        if (end != word.c_str() + word.size() || !std::isfinite(v)) {
            ok = false;
            return {};
        }
        out.push_back(v);
    }
    ok = !out.empty();
    return out;
}

class MitsubaReader {
public:
    std::vector<SceneMaterial> materials;

    void read_file(const std::string& path, int depth) {
        const std::string text = read_scene_text(path, depth, "<include>");
        pugi::xml_document doc;
        pugi::xml_parse_result result = doc.load_buffer(text.data(), text.size());
        if (!result) {
            const auto offset = static_cast<std::size_t>(std::max<std::ptrdiff_t>(0, result.offset));
            const long line =
                1 + std::count(text.begin(), text.begin() + std::min(offset, text.size()), '\n');
            throw InputError(path + ":" + std::to_string(line) + ": XML error: " +
                             result.description());
        }
        pugi::xml_node scene = doc.child("scene");
        if (!scene)
            throw InputError(path + ": the root element must be <scene> (a Mitsuba scene file)");
        const std::string version = scene.attribute("version").as_string();
        const bool legacy = version.rfind("0.", 0) == 0;
        for (pugi::xml_node d : scene.children("default")) {
            const std::string name = d.attribute("name").as_string();
            if (name.empty())
                throw InputError(path + ": scene/default: missing attribute 'name'");
            defaults_.emplace(name, d.attribute("value").as_string());  // first one wins
        }
        file_ = path;
        legacy_ = legacy;
        std::map<std::string, int> counts;
        for (pugi::xml_node child : scene.children()) {
            const std::string tag = child.name();
            const std::string path_here = "scene/" + tag + "[" + std::to_string(counts[tag]++) + "]";
            if (tag == "bsdf") {
                const std::string id = child.attribute("id").as_string();
                std::size_t first = read_bsdf(child, path_here, id, false, "");
                if (!id.empty()) named_[id] = first;
            } else if (tag == "shape") {
                read_shape(child, path_here);
            } else if (tag == "include") {
                const std::string file = substitute(child.attribute("filename").as_string(),
                                                    path_here);
                const std::string saved_file = file_;
                const bool saved_legacy = legacy_;
                read_file(resolve(file), depth + 1);
                file_ = saved_file;
                legacy_ = saved_legacy;
            }
        }
        for (const auto& [id, where] : pending_refs_) {
            auto it = named_.find(id);
            if (it == named_.end())
                throw InputError(where + ": <ref id=\"" + id + "\"> names no BSDF of the scene");
            mark_used(it->second);
        }
        pending_refs_.clear();
    }

private:
    std::map<std::string, std::string> defaults_;
    std::map<std::string, std::size_t> named_;  // id -> index of its material
    std::vector<std::pair<std::string, std::string>> pending_refs_;
    std::string file_;
    bool legacy_ = false;
    int anonymous_count_ = 0;

    std::string where(const std::string& element_path) const { return file_ + ": " + element_path; }

    std::string resolve(const std::string& name) const {
        if (!name.empty() && name[0] == '/') return name;
        const auto slash = file_.rfind('/');
        return (slash == std::string::npos ? std::string() : file_.substr(0, slash + 1)) + name;
    }

    std::string substitute(const std::string& value, const std::string& element_path) const {
        std::string out;
        for (std::size_t i = 0; i < value.size(); ++i) {
            if (value[i] != '$') {
                out += value[i];
                continue;
            }
            std::size_t j = i + 1;
            while (j < value.size() &&
                   (std::isalnum(static_cast<unsigned char>(value[j])) || value[j] == '_'))
                ++j;
            const std::string name = value.substr(i + 1, j - i - 1);
            auto it = defaults_.find(name);
            if (name.empty() || it == defaults_.end())
                throw InputError(where(element_path) + ": '$" + name +
                                 "' has no <default name=\"" + name + "\" .../>");
            out += it->second;
            i = j - 1;
        }
        return out;
    }

    void mark_used(std::size_t index) {
        materials[index].used = true;
        // The parts of a blendbsdf follow it in the list and share its use.
        for (std::size_t k = index + 1; k < materials.size() &&
                                        materials[k].wrapped_in == "blendbsdf:" + materials[index].name;
             ++k)
            materials[k].used = true;
    }

    void read_shape(pugi::xml_node shape, const std::string& path) {
        std::map<std::string, int> counts;
        for (pugi::xml_node child : shape.children()) {
            const std::string tag = child.name();
            const std::string here = path + "/" + tag + "[" + std::to_string(counts[tag]++) + "]";
            if (tag == "bsdf") {
                const std::string id = child.attribute("id").as_string();
                std::size_t first = read_bsdf(child, here, id, true, "");
                if (!id.empty()) named_[id] = first;
            } else if (tag == "ref") {
                const std::string id = substitute(child.attribute("id").as_string(), here);
                pending_refs_.emplace_back(id, where(here));
            }
        }
    }

    // Reads one <bsdf> (unwrapping wrappers); returns the index of the
    // material that represents it.
    std::size_t read_bsdf(pugi::xml_node node, const std::string& path, const std::string& id,
                          bool used, const std::string& wrapped_in) {
        const std::string type = substitute(node.attribute("type").as_string(), path);
        if (type.empty()) throw InputError(where(path) + ": <bsdf> without a 'type' attribute");
        if (kWrappers.count(type)) {
            pugi::xml_node inner = node.child("bsdf");
            if (!inner) {
                pugi::xml_node ref = node.child("ref");
                if (ref) {
                    // A wrapper around a named BSDF: the wrapped BSDF is the material.
                    const std::string rid = substitute(ref.attribute("id").as_string(), path);
                    pending_refs_.emplace_back(rid, where(path + "/ref"));
                    SceneMaterial m;
                    m.name = id.empty() ? "anonymous-" + std::to_string(++anonymous_count_) : id;
                    m.anonymous = id.empty();
                    m.format = legacy_ ? "mitsuba-0.6" : "mitsuba";
                    m.type = type;
                    m.where = where(path);
                    m.used = false;  // the referenced BSDF carries the table
                    m.wrapped_in = "ref:" + rid;
                    materials.push_back(std::move(m));
                    return materials.size() - 1;
                }
                throw InputError(where(path) + ": <bsdf type=\"" + type +
                                 "\"> must contain the BSDF it wraps");
            }
            const std::string inner_id = inner.attribute("id").as_string();
            const std::string name = !id.empty() ? id : inner_id;
            const std::string chain = wrapped_in.empty() ? type : wrapped_in + "/" + type;
            return read_bsdf(inner, path + "/bsdf[0]", name, used, chain);
        }
        SceneMaterial m;
        m.anonymous = id.empty();
        m.name = id.empty() ? "anonymous-" + std::to_string(++anonymous_count_) : id;
        m.format = legacy_ ? "mitsuba-0.6" : "mitsuba";
        m.type = type;
        m.where = where(path);
        m.used = used;
        m.wrapped_in = wrapped_in;
        std::map<std::string, int> counts;
        std::vector<pugi::xml_node> parts;
        for (pugi::xml_node child : node.children()) {
            const std::string tag = child.name();
            const std::string here = path + "/" + tag + "[" + std::to_string(counts[tag]++) + "]";
            if (tag == "bsdf") {
                parts.push_back(child);
                continue;
            }
            read_parameter(child, tag, here, m);
        }
        materials.push_back(std::move(m));
        const std::size_t index = materials.size() - 1;
        int part = 0;
        for (pugi::xml_node p : parts) {
            const std::string part_id = p.attribute("id").as_string();
            read_bsdf(p, path + "/bsdf[" + std::to_string(part) + "]",
                      part_id.empty() ? materials[index].name + "." + std::to_string(part)
                                      : part_id,
                      used, type + ":" + materials[index].name);
            ++part;
        }
        return index;
    }

    void read_parameter(pugi::xml_node child, const std::string& tag, const std::string& here,
                        SceneMaterial& m) {
        const std::string raw_name = substitute(child.attribute("name").as_string(), here);
        if (raw_name.empty()) return;  // e.g. <transform>: not a BSDF parameter
        const std::string name = legacy_ ? snake_case(raw_name) : raw_name;
        SceneParameter p;
        p.type = tag;
        p.where = where(here + "(name=" + raw_name + ")");
        if (tag == "texture") {
            const std::string ttype = substitute(child.attribute("type").as_string(), here);
            if (ttype == "bitmap") {
                std::string filename;
                bool raw = false;
                for (pugi::xml_node q : child.children()) {
                    const std::string qn = q.attribute("name").as_string();
                    if (qn == "filename")
                        filename = substitute(q.attribute("value").as_string(), here);
                    if (qn == "raw")
                        raw = substitute(q.attribute("value").as_string(), here) == "true";
                }
                if (filename.empty())
                    throw InputError(p.where + ": bitmap texture without a 'filename' string");
                const std::string file = resolve(filename);
                ImageRange r = image_value_range(file, raw ? "linear" : "sRGB");
                p.type = "float";
                p.image = file;
                p.image_missing = r.missing;
                p.image_min = r.min;
                p.image_max = r.max;
            } else {
                p.type = "float";
                p.image = "(procedural " + ttype + " texture)";
                p.image_missing = true;
            }
            m.parameters[name] = p;
            return;
        }
        const std::string value = substitute(child.attribute("value").as_string(), here);
        if (tag == "float" || tag == "integer" || tag == "rgb" || tag == "spectrum") {
            bool ok = false;
            p.numbers = parse_numbers(value, ok);
            if (!ok) {
                if (tag == "float" || tag == "integer")
                    throw InputError(p.where + ": value '" + value + "' is not a number");
                p.texts.push_back(value);  // e.g. a spectrum given as wavelength:value pairs
            }
        } else {
            p.texts.push_back(value);
        }
        m.parameters[name] = p;
    }
};

}  // namespace

std::vector<SceneMaterial> read_mitsuba_scene(const std::string& path) {
    MitsubaReader reader;
    reader.read_file(path, 0);
    return reader.materials;
}

}  // namespace brdftab::scene_detail
