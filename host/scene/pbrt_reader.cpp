// pbrt_reader.cpp — the materials of a pbrt-v3 or pbrt-v4 scene file.
//
// Only what `brdftab scene` needs is interpreted: Material, MakeNamedMaterial,
// NamedMaterial, Texture, Include/Import, AttributeBegin/End (the current
// material is part of the graphics state), Shape and ObjectInstance (which
// mark the current material as used).  Every other directive is skipped with
// its arguments.  The tokenizer is ours; the grammar follows the pbrt file
// format documentation: "type name" parameter declarations followed by one
// value or a bracketed list, `#` comments, quoted strings, bare numbers and
// (pbrt-v4) bare booleans.
#include "host/scene/scene_internal.h"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>

#include "host/core/error.h"

namespace brdftab::scene_detail {
namespace {

struct Token {
    enum Kind { Word, String, Number, Open, Close, End } kind = End;
    std::string text;
    double number = 0;
    int line = 0, column = 0;
};

class Tokenizer {
public:
    Tokenizer(std::string text, std::string file) : text_(std::move(text)), file_(std::move(file)) {}

    const std::string& file() const { return file_; }

    std::string where(const Token& t) const {
        return file_ + ":" + std::to_string(t.line) + ":" + std::to_string(t.column);
    }

    Token peek() {
        if (!peeked_) {
            next_token_ = read();
            peeked_ = true;
        }
        return next_token_;
    }

    Token next() {
        Token t = peek();
        peeked_ = false;
        return t;
    }

private:
    Token read() {
        skip_blank_and_comments();
        Token t;
        t.line = line_;
        t.column = column_;
        if (pos_ >= text_.size()) return t;  // End
        const char c = text_[pos_];
        if (c == '[') {
            advance();
            t.kind = Token::Open;
            return t;
        }
        if (c == ']') {
            advance();
            t.kind = Token::Close;
            return t;
        }
        if (c == '"') {
            advance();
            t.kind = Token::String;
            while (true) {
                if (pos_ >= text_.size() || text_[pos_] == '\n')
                    throw InputError(where(t) + ": unterminated string (a '\"' is missing)");
                char ch = text_[pos_];
                advance();
                if (ch == '"') break;
                if (ch == '\\' && pos_ < text_.size()) {
                    char esc = text_[pos_];
                    advance();
                    switch (esc) {
                        case 'n': ch = '\n'; break;
                        case 't': ch = '\t'; break;
                        default: ch = esc; break;  // \" \\ and anything else: itself
                    }
                }
                t.text += ch;
            }
            return t;
        }
        // A bare word or number: up to blank, bracket, quote or comment.
        std::size_t start = pos_;
        while (pos_ < text_.size()) {
            const char d = text_[pos_];
            if (std::isspace(static_cast<unsigned char>(d)) || d == '[' || d == ']' || d == '"' ||
                d == '#')
                break;
            advance();
        }
        t.text = text_.substr(start, pos_ - start);
        const char first = t.text[0];
        if (std::isdigit(static_cast<unsigned char>(first)) || first == '-' || first == '+' ||
            first == '.') {
            char* end = nullptr;
            t.number = std::strtod(t.text.c_str(), &end);
            if (end != t.text.c_str() + t.text.size() || !std::isfinite(t.number))
                throw InputError(where(t) + ": '" + t.text + "' is not a number");
            t.kind = Token::Number;
        } else {
            t.kind = Token::Word;
        }
        return t;
    }

    void advance() {
        if (text_[pos_] == '\n') {
            ++line_;
            column_ = 1;
        } else {
            ++column_;
        }
        ++pos_;
    }

    void skip_blank_and_comments() {
        while (pos_ < text_.size()) {
            const char c = text_[pos_];
            if (c == '#') {
                while (pos_ < text_.size() && text_[pos_] != '\n') advance();
            } else if (std::isspace(static_cast<unsigned char>(c))) {
                advance();
            } else {
                break;
            }
        }
    }

    std::string text_, file_;
    std::size_t pos_ = 0;
    int line_ = 1, column_ = 1;
    bool peeked_ = false;
    Token next_token_;
};

// Material types of each pbrt version (pbrt-v3 src/materials, pbrt-v4
// src/pbrt/materials.h); used to say which version a material follows.
const std::set<std::string> kPbrtV3Types = {"matte",  "plastic",   "glass",    "metal",
                                            "mirror", "substrate", "uber",     "translucent",
                                            "fourier", "kdsubsurface", "disney", "none"};
const std::set<std::string> kPbrtV4Types = {
    "diffuse",      "dielectric", "coateddiffuse", "conductor", "coatedconductor",
    "thindielectric", "measured", "diffusetransmission", "interface"};

std::string version_of(const std::string& type) {
    if (kPbrtV3Types.count(type)) return "pbrt-v3";
    if (kPbrtV4Types.count(type)) return "pbrt-v4";
    return "pbrt";  // hair, mix, subsurface: both versions
}

struct GraphicsState {
    std::string material;  // key into `materials` ("" = pbrt's default)
};

class PbrtReader {
public:
    std::vector<SceneMaterial> materials;

    void read_file(const std::string& path, int depth) {
        Tokenizer tok(read_scene_text(path, depth, "Include/Import"), path);
        parse(tok, depth);
    }

private:
    std::map<std::string, std::size_t> named_;  // named material -> index
    std::map<std::string, SceneParameter> float_textures_;  // texture name -> its value/range
    std::vector<GraphicsState> stack_{GraphicsState{}};
    int anonymous_count_ = 0;

    static std::string directory_of(const std::string& path) {
        const auto slash = path.rfind('/');
        return slash == std::string::npos ? std::string() : path.substr(0, slash + 1);
    }

    static std::string resolve(const std::string& base_file, const std::string& name) {
        if (!name.empty() && name[0] == '/') return name;
        return directory_of(base_file) + name;
    }

    std::string expect_string(Tokenizer& tok, const std::string& directive, const char* what) {
        Token t = tok.next();
        if (t.kind != Token::String)
            throw InputError(tok.where(t) + ": " + directive + " expects " + what +
                             " as a quoted string");
        return t.text;
    }

    // The "type name" value... list after a directive's fixed arguments.
    std::map<std::string, SceneParameter> read_parameters(Tokenizer& tok) {
        std::map<std::string, SceneParameter> params;
        while (tok.peek().kind == Token::String) {
            Token decl = tok.next();
            std::istringstream words(decl.text);
            std::string type, name, extra;
            words >> type >> name;
            if (type.empty() || name.empty() || (words >> extra))
                throw InputError(tok.where(decl) + ": parameter declaration '" + decl.text +
                                 "' must be \"type name\"");
            SceneParameter p;
            p.type = type;
            p.where = tok.where(decl);
            auto add = [&](const Token& v) {
                if (v.kind == Token::Number) {
                    p.numbers.push_back(v.number);
                } else if (v.kind == Token::String ||
                           (v.kind == Token::Word && (v.text == "true" || v.text == "false"))) {
                    p.texts.push_back(v.text);
                } else {
                    throw InputError(tok.where(v) + ": parameter '" + name +
                                     "': expected a value, found " +
                                     (v.kind == Token::End ? std::string("the end of the file")
                                                           : "'" + v.text + "'"));
                }
            };
            Token v = tok.next();
            if (v.kind == Token::Open) {
                while (true) {
                    Token item = tok.next();
                    if (item.kind == Token::Close) break;
                    if (item.kind == Token::End || item.kind == Token::Open)
                        throw InputError(tok.where(v) + ": parameter '" + name +
                                         "': '[' without a matching ']'");
                    add(item);
                }
            } else {
                add(v);
            }
            params[name] = std::move(p);
        }
        return params;
    }

    // Replace "texture name" references to known float textures by what the
    // texture holds (a constant, or an image's value range).
    void resolve_textures(std::map<std::string, SceneParameter>& params) {
        for (auto& [name, p] : params) {
            if (p.type != "texture" || p.texts.empty()) continue;
            auto it = float_textures_.find(p.texts[0]);
            if (it == float_textures_.end()) continue;  // spectrum texture or unknown: left as is
            const std::string where = p.where;
            p = it->second;
            p.where = where;
        }
    }

    void skip_arguments(Tokenizer& tok) {
        while (true) {
            Token t = tok.peek();
            if (t.kind == Token::End) return;
            if (t.kind == Token::Word && t.text != "true" && t.text != "false") return;
            tok.next();
        }
    }

    SceneMaterial make_material(const std::string& type, const Token& at, Tokenizer& tok,
                                std::map<std::string, SceneParameter> params) {
        SceneMaterial m;
        m.type = type;
        m.format = version_of(type);
        m.where = tok.where(at);
        resolve_textures(params);
        m.parameters = std::move(params);
        m.used = false;
        return m;
    }

    void parse(Tokenizer& tok, int depth) {
        while (true) {
            Token t = tok.next();
            if (t.kind == Token::End) return;
            if (t.kind != Token::Word)
                throw InputError(tok.where(t) + ": expected a directive (e.g. Material, Shape), "
                                                "found " +
                                 (t.kind == Token::String ? "\"" + t.text + "\""
                                                          : "'" + t.text + "'"));
            const std::string& d = t.text;
            if (d == "AttributeBegin" || d == "TransformBegin" || d == "ObjectBegin") {
                if (d == "ObjectBegin") expect_string(tok, d, "the object's name");
                stack_.push_back(stack_.back());
            } else if (d == "AttributeEnd" || d == "TransformEnd" || d == "ObjectEnd") {
                if (stack_.size() == 1)
                    throw InputError(tok.where(t) + ": " + d + " without a matching begin");
                stack_.pop_back();
            } else if (d == "Material") {
                const std::string type = expect_string(tok, d, "the material type");
                auto params = read_parameters(tok);
                SceneMaterial m = make_material(type, t, tok, std::move(params));
                m.anonymous = true;
                m.name = "anonymous-" + std::to_string(++anonymous_count_);
                materials.push_back(std::move(m));
                stack_.back().material = "#" + std::to_string(materials.size() - 1);
            } else if (d == "MakeNamedMaterial") {
                const std::string name = expect_string(tok, d, "the material's name");
                auto params = read_parameters(tok);
                auto type_it = params.find("type");
                if (type_it == params.end() || type_it->second.texts.empty())
                    throw InputError(tok.where(t) + ": MakeNamedMaterial \"" + name +
                                     "\" has no \"string type\" parameter");
                const std::string type = type_it->second.texts[0];
                params.erase(type_it);
                SceneMaterial m = make_material(type, t, tok, std::move(params));
                m.name = name;
                auto existing = named_.find(name);
                if (existing != named_.end()) {
                    // pbrt lets a later definition replace an earlier one.
                    m.used = materials[existing->second].used;
                    materials[existing->second] = std::move(m);
                } else {
                    materials.push_back(std::move(m));
                    named_[name] = materials.size() - 1;
                }
            } else if (d == "NamedMaterial") {
                const std::string name = expect_string(tok, d, "the material's name");
                if (!named_.count(name))
                    throw InputError(tok.where(t) + ": NamedMaterial \"" + name +
                                     "\" was not defined by MakeNamedMaterial before");
                stack_.back().material = name;
            } else if (d == "Texture") {
                const std::string name = expect_string(tok, d, "the texture's name");
                const std::string kind = expect_string(tok, d, "the texture type");
                const std::string cls = expect_string(tok, d, "the texture class");
                auto params = read_parameters(tok);
                if (kind == "float") float_textures_[name] = float_texture(tok, cls, params, t);
            } else if (d == "Include" || d == "Import") {
                const std::string file = expect_string(tok, d, "a file name");
                read_file(resolve(tok.file(), file), depth + 1);
            } else if (d == "Shape" || d == "ObjectInstance") {
                expect_string(tok, d, d == "Shape" ? "the shape type" : "the object's name");
                read_parameters(tok);
                mark_current_used();
            } else {
                skip_arguments(tok);
            }
        }
    }

    void mark_current_used() {
        const std::string& cur = stack_.back().material;
        if (cur.empty()) return;
        if (cur[0] == '#') {
            materials[std::stoul(cur.substr(1))].used = true;
        } else {
            materials[named_.at(cur)].used = true;
        }
    }

    SceneParameter float_texture(Tokenizer& tok, const std::string& cls,
                                 const std::map<std::string, SceneParameter>& params,
                                 const Token& at) {
        SceneParameter p;
        p.type = "float";
        p.where = tok.where(at);
        if (cls == "constant") {
            auto v = params.find("value");
            p.numbers.push_back(v != params.end() && !v->second.numbers.empty()
                                    ? v->second.numbers[0]
                                    : 1.0);  // pbrt's default constant value
            return p;
        }
        if (cls == "imagemap") {
            auto f = params.find("filename");
            if (f == params.end() || f->second.texts.empty())
                throw InputError(tok.where(at) + ": imagemap texture without \"string filename\"");
            std::string encoding = "sRGB";  // pbrt-v4's default for 8-bit images
            auto e = params.find("encoding");
            if (e != params.end() && !e->second.texts.empty()) encoding = e->second.texts[0];
            double scale = 1;
            auto s = params.find("scale");
            if (s != params.end() && !s->second.numbers.empty()) scale = s->second.numbers[0];
            const std::string file = resolve(tok.file(), f->second.texts[0]);
            p.image = file;
            ImageRange r = image_value_range(file, encoding);
            p.image_missing = r.missing;
            p.image_min = r.min * scale;
            p.image_max = r.max * scale;
            if (p.image_min > p.image_max) std::swap(p.image_min, p.image_max);
            return p;
        }
        // Procedural float textures (scale, mix, fbm, ...): range unknown.
        p.image = "(procedural " + cls + " texture)";
        p.image_missing = true;
        return p;
    }
};

}  // namespace

std::vector<SceneMaterial> read_pbrt_scene(const std::string& path) {
    PbrtReader reader;
    reader.read_file(path, 0);
    return reader.materials;
}

}  // namespace brdftab::scene_detail
