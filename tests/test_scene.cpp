// Tests of host/scene: reading pbrt-v3/v4, Mitsuba 0.6/3 and brdftab scene
// files, mapping materials with each renderer's conventions, and sharing
// tables.  Expected values come from the renderers' documented conventions
// (pbrt-v4 alpha = sqrt(roughness); pbrt-v3's remap evaluated independently;
// Mitsuba's named IORs; Mitsuba 0.6 sigma = alpha / sqrt(2)), not from our
// output.
#include <doctest/doctest.h>

#include <png.h>
#include <ImfRgbaFile.h>
#include <ImfArray.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

#include "host/core/error.h"
#include "host/scene/scene.h"
#include "host/spec/spec.h"
#include "test_support.h"

using namespace brdftab;
using brdftab::test::kPi;

namespace {

const std::string kScenes = std::string(BT_SOURCE_DIR) + "/tests/data/scenes/";

const MappedMaterial& by_name(const ScenePlan& plan, const std::string& name) {
    for (const MappedMaterial& m : plan.materials)
        if (m.source.name == name) return m;
    FAIL("no material " << name);
    throw 0;
}

ScenePlan plan_of(const std::string& file, ScenePurpose purpose = ScenePurpose::All) {
    ScenePlanSettings s;
    s.purpose = purpose;
    return plan_scene_tables(read_scene_materials(kScenes + file), s);
}

// Which table set serves a material for a purpose ("" when none).
std::string set_of(const ScenePlan& plan, const std::string& material, const std::string& purpose) {
    for (const SceneTableSet& set : plan.sets)
        if (set.purpose == purpose)
            for (const std::string& m : set.materials)
                if (m == material) return set.id;
    return "";
}

// A scratch directory with files written by the test.
struct Scratch {
    std::filesystem::path dir;
    Scratch() {
        dir = std::filesystem::temp_directory_path() /
              ("bt-scene-" + std::to_string(::getpid()) + "-" + std::to_string(counter()++));
        std::filesystem::create_directories(dir);
    }
    ~Scratch() { std::filesystem::remove_all(dir); }
    std::string write(const std::string& name, const std::string& text) const {
        std::ofstream(dir / name) << text;
        return (dir / name).string();
    }
    static int& counter() {
        static int n = 0;
        return n;
    }
};

std::string error_of(const std::string& path) {
    try {
        plan_scene_tables(read_scene_materials(path), ScenePlanSettings{});
    } catch (const InputError& e) {
        return e.what();
    }
    return "(no error)";
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

TEST_CASE("pbrt-v4: dielectric, coateddiffuse, includes, textures, sharing, unused") {
    const ScenePlan plan = plan_of("pbrt_v4.pbrt");
    CHECK(plan.materials.size() == 9);

    const MappedMaterial& glass = by_name(plan, "glass");
    CHECK(glass.status == MaterialStatus::Tabulated);
    CHECK(glass.model == "rough-dielectric");
    CHECK(glass.source.format == "pbrt-v4");
    // pbrt-v4 RoughnessToAlpha: alpha = sqrt(roughness).
    CHECK(glass.parameters.at("alpha") == doctest::Approx(std::sqrt(0.1)).epsilon(1e-15));
    CHECK(glass.parameters.at("eta") == 1.5);  // given as a bare value
    CHECK(glass.options.at("distribution") == "ggx");
    CHECK(glass.options.at("shadowing") == "height-correlated");

    // Roughness 0 (the default) is smooth: no table.
    CHECK(by_name(plan, "window").status == MaterialStatus::NoTableNeeded);
    CHECK(by_name(plan, "gold").status == MaterialStatus::Unsupported);
    const MappedMaterial& unused = by_name(plan, "never-used");
    CHECK(unused.status == MaterialStatus::NoTableNeeded);
    CHECK(contains(unused.reason, "no shape"));

    const MappedMaterial& red = by_name(plan, "lacquer-red");
    CHECK(red.model == "interfaced-lambertian");
    CHECK(red.parameters.at("alpha") == doctest::Approx(0.2).epsilon(1e-15));
    CHECK(red.parameters.at("ni") == 1.5);
    CHECK(red.options.at("distribution") == "ggx-smith");
    CHECK(red.factored.at("kd") == nlohmann::json({0.6, 0.1, 0.1}));
    // Kd is factored out: red and blue lacquer share their tables.
    CHECK(set_of(plan, "lacquer-red", "bsdf") == set_of(plan, "lacquer-blue", "bsdf"));
    CHECK(set_of(plan, "lacquer-red", "albedo") == set_of(plan, "lacquer-blue", "albedo"));
    CHECK(set_of(plan, "lacquer-red", "bsdf") != set_of(plan, "glass", "bsdf"));

    // An anonymous material whose roughness texture file is missing: alpha
    // becomes an axis over the model's whole range, and a note says so.
    const MappedMaterial& textured = by_name(plan, "anonymous-2");
    CHECK(textured.source.anonymous);
    CHECK(textured.parameters.at("eta") == 1.33);
    REQUIRE(textured.parameter_ranges.count("alpha") == 1);
    CHECK(textured.parameter_ranges.at("alpha").second == 4.0);
    REQUIRE(textured.notes.size() == 1);
    CHECK(contains(textured.notes[0], "missing-roughness.png"));

    // Defined in an included file; remaproughness false: alpha = roughness.
    const MappedMaterial& frosted = by_name(plan, "frosted");
    CHECK(contains(frosted.source.where, "pbrt_v4_include.pbrt:2:"));
    CHECK(frosted.parameters.at("alpha") == 0.0625);
}

TEST_CASE("pbrt-v3: matte, glass with the v3 remap, plastic") {
    const ScenePlan plan = plan_of("pbrt_v3.pbrt");
    REQUIRE(plan.materials.size() == 6);
    const MappedMaterial& matte = by_name(plan, "anonymous-1");
    CHECK(matte.source.format == "pbrt-v3");
    CHECK(matte.model == "oren-nayar");
    CHECK(matte.parameters.at("sigma") == 20.0);  // degrees, as pbrt-v3 reads it
    CHECK(matte.factored.at("rho") == nlohmann::json({0.8, 0.7, 0.6}));
    CHECK(set_of(plan, "anonymous-1", "bsdf") == set_of(plan, "anonymous-2", "bsdf"));
    CHECK(by_name(plan, "anonymous-3").status == MaterialStatus::NoTableNeeded);  // sigma 0
    const MappedMaterial& glass = by_name(plan, "anonymous-4");
    // pbrt-v3's quartic in log(0.05), evaluated independently of our code.
    CHECK(glass.parameters.at("alpha") == doctest::Approx(0.31254748723576287).epsilon(1e-12));
    CHECK(pbrt_v3_roughness_to_alpha(0.05) ==
          doctest::Approx(0.31254748723576287).epsilon(1e-12));
    CHECK(by_name(plan, "anonymous-5").status == MaterialStatus::Unsupported);  // anisotropic
    CHECK(by_name(plan, "anonymous-6").status == MaterialStatus::Unsupported);  // plastic
}

TEST_CASE("Mitsuba 3: named IORs, defaults, twosided, refs, sharing") {
    const ScenePlan plan = plan_of("mitsuba3.xml");
    REQUIRE(plan.materials.size() == 7);
    const MappedMaterial& bottle = by_name(plan, "bottle");
    CHECK(bottle.parameters.at("alpha") == 0.2);  // from <default name="rough">
    CHECK(bottle.parameters.at("eta") == doctest::Approx(1.5046 / 1.000277).epsilon(1e-15));
    CHECK(bottle.options.at("distribution") == "ggx");
    CHECK(bottle.options.at("shadowing") == "separable");
    // Mitsuba's defaults: beckmann, alpha 0.1, bk7 inside, air outside.
    const MappedMaterial& plain = by_name(plan, "default-glass");
    CHECK(plain.options.at("distribution") == "beckmann");
    CHECK(plain.parameters.at("alpha") == 0.1);
    CHECK(plain.parameters.at("eta") == doctest::Approx(1.5046 / 1.000277).epsilon(1e-15));

    const MappedMaterial& red = by_name(plan, "red-plastic");
    CHECK(red.source.wrapped_in == "twosided");
    CHECK(red.model == "interfaced-lambertian");
    CHECK(red.parameters.at("ni") == doctest::Approx(1.49 / 1.000277).epsilon(1e-15));
    CHECK(red.factored.at("kd") == nlohmann::json({0.7, 0.1, 0.1}));
    CHECK(by_name(plan, "green-plastic").factored.at("kd") == nlohmann::json({0.1, 0.7, 0.1}));
    CHECK(set_of(plan, "red-plastic", "bsdf") == set_of(plan, "green-plastic", "bsdf"));

    CHECK(by_name(plan, "unused-white").status == MaterialStatus::NoTableNeeded);
    CHECK(by_name(plan, "anonymous-1").status == MaterialStatus::NoTableNeeded);  // diffuse
    CHECK(by_name(plan, "anonymous-2").status == MaterialStatus::Unsupported);    // conductor
}

TEST_CASE("Mitsuba 0.6: camelCase names and roughdiffuse") {
    const ScenePlan plan = plan_of("mitsuba06.xml");
    const MappedMaterial& clay = by_name(plan, "clay");
    CHECK(clay.source.format == "mitsuba-0.6");
    CHECK(clay.model == "oren-nayar");
    // sigma = alpha / sqrt(2) radians, in degrees.
    CHECK(clay.parameters.at("sigma") ==
          doctest::Approx(0.3 / std::sqrt(2.0) * 180 / kPi).epsilon(1e-14));
    const MappedMaterial& water = by_name(plan, "water-surface");
    CHECK(water.parameters.at("eta") == doctest::Approx(1.3330).epsilon(1e-15));  // intIOR water, extIOR 1
}

TEST_CASE("brdftab material list") {
    const ScenePlan plan = plan_of("materials.toml");
    CHECK(by_name(plan, "moon-dust").model == "lambert-sphere");
    CHECK(by_name(plan, "moon-dust").parameters.at("c") == 0.9);
    CHECK(by_name(plan, "rusty-grains").options.at("base") == "lambertian");
    CHECK(by_name(plan, "glass-sheet").parameters.at("alpha") == 0.3);
}

TEST_CASE("table sets are valid specs with unique table names, and every tabulated material has one") {
    for (const char* file :
         {"pbrt_v4.pbrt", "pbrt_v3.pbrt", "mitsuba3.xml", "mitsuba06.xml", "materials.toml"}) {
        CAPTURE(file);
        const ScenePlan plan = plan_of(file);
        std::set<std::string> names;
        for (const SceneTableSet& set : plan.sets) {
            CAPTURE(set.spec_text);
            const Spec spec = parse_spec_string(set.spec_text, set.id);
            CHECK(spec.model == set.model);
            for (const std::string& t : set.tables) CHECK(names.insert(t).second);
            CHECK(std::find(set.tables.begin(), set.tables.end(), set.main_table) !=
                  set.tables.end());
        }
        const nlohmann::json manifest = scene_manifest(plan, file, "out.h5");
        for (const auto& m : manifest["materials"]) {
            if (m["status"] == "tabulated") {
                CHECK(names.count(m["table"].get<std::string>()) == 1);
            } else {
                CHECK(m["table"].is_null());
            }
        }
    }
    // --for bsdf / albedo: only those sets.
    for (const SceneTableSet& s : plan_of("mitsuba3.xml", ScenePurpose::Bsdf).sets)
        CHECK(s.purpose == "bsdf");
    for (const SceneTableSet& s : plan_of("mitsuba3.xml", ScenePurpose::Albedo).sets)
        CHECK(s.purpose == "albedo");
}

TEST_CASE("a PNG roughness texture becomes an axis over the values it holds") {
    Scratch s;
    // A 2x1 grey image with codes 51 and 204.
    png_image image{};
    image.version = PNG_IMAGE_VERSION;
    image.width = 2;
    image.height = 1;
    image.format = PNG_FORMAT_GRAY;
    const png_byte pixels[2] = {51, 204};
    REQUIRE(png_image_write_to_file(&image, (s.dir / "rough.png").c_str(), 0, pixels, 0, nullptr));
    const std::string scene = s.write(
        "t.pbrt",
        "Texture \"r\" \"float\" \"imagemap\" \"string filename\" \"rough.png\" \"string encoding\" "
        "\"linear\"\nTexture \"g\" \"float\" \"imagemap\" \"string filename\" \"rough.png\"\n"
        "Material \"dielectric\" \"texture roughness\" \"r\"\nShape \"sphere\"\n"
        "Material \"dielectric\" \"texture roughness\" \"g\"\nShape \"sphere\"\n");
    const ScenePlan plan = plan_scene_tables(read_scene_materials(scene), ScenePlanSettings{});
    const auto& linear = by_name(plan, "anonymous-1").parameter_ranges.at("alpha");
    CHECK(linear.first == doctest::Approx(std::sqrt(0.2)).epsilon(1e-12));
    CHECK(linear.second == doctest::Approx(std::sqrt(0.8)).epsilon(1e-12));
    // pbrt-v4's default encoding of 8-bit images is sRGB: sRGB(0.2) = 0.0331048,
    // sRGB(0.8) = 0.6038273 (IEC 61966-2-1).
    const auto& srgb = by_name(plan, "anonymous-2").parameter_ranges.at("alpha");
    CHECK(srgb.first == doctest::Approx(std::sqrt(0.033104766570885055)).epsilon(1e-9));
    CHECK(srgb.second == doctest::Approx(std::sqrt(0.6038273388553378)).epsilon(1e-9));
    // The axis reaches the table's spec.
    bool found = false;
    for (const SceneTableSet& set : plan.sets)
        if (contains(set.spec_text, "name = \"alpha\"")) found = true;
    CHECK(found);
}

TEST_CASE("Mitsuba bitmap textures (PNG raw, EXR) become axes over their values") {
    Scratch s;
    png_image image{};
    image.version = PNG_IMAGE_VERSION;
    image.width = 3;
    image.height = 1;
    image.format = PNG_FORMAT_GRAY;
    const png_byte pixels[3] = {102, 26, 153};  // 0.4, 0.10196, 0.6 as raw (linear) values
    REQUIRE(png_image_write_to_file(&image, (s.dir / "a.png").c_str(), 0, pixels, 0, nullptr));
    {
        // A 2x2 half-float EXR holding alphas 0.05 .. 0.5 in its R channel.
        Imf::Array2D<Imf::Rgba> px(2, 2);
        const float values[4] = {0.05f, 0.5f, 0.25f, 0.125f};
        for (int k = 0; k < 4; ++k) px[k / 2][k % 2] = Imf::Rgba(values[k], 0, 0, 1);
        Imf::RgbaOutputFile out((s.dir / "a.exr").c_str(), 2, 2, Imf::WRITE_RGBA);
        out.setFrameBuffer(&px[0][0], 1, 2);
        out.writePixels(2);
    }
    const std::string scene = s.write(
        "t.xml",
        "<scene version=\"3.0.0\">"
        "<bsdf type=\"roughdielectric\" id=\"png\"><texture type=\"bitmap\" name=\"alpha\">"
        "<string name=\"filename\" value=\"a.png\"/><boolean name=\"raw\" value=\"true\"/>"
        "</texture></bsdf>"
        "<bsdf type=\"roughdielectric\" id=\"exr\"><texture type=\"bitmap\" name=\"alpha\">"
        "<string name=\"filename\" value=\"a.exr\"/></texture></bsdf>"
        "<shape type=\"sphere\"><ref id=\"png\"/></shape>"
        "<shape type=\"sphere\"><ref id=\"exr\"/></shape></scene>");
    const ScenePlan plan = plan_scene_tables(read_scene_materials(scene), ScenePlanSettings{});
    const auto& png_range = by_name(plan, "png").parameter_ranges.at("alpha");
    CHECK(png_range.first == doctest::Approx(26 / 255.0).epsilon(1e-12));
    CHECK(png_range.second == doctest::Approx(153 / 255.0).epsilon(1e-12));
    const auto& exr_range = by_name(plan, "exr").parameter_ranges.at("alpha");
    // half precision of 0.05 and 0.5
    CHECK(exr_range.first == doctest::Approx(0.05).epsilon(1e-3));
    CHECK(exr_range.second == 0.5);
    // Different textures: different tables (the albedos: the BSDF, a closed
    // form, has none).
    CHECK(set_of(plan, "png", "albedo") != set_of(plan, "exr", "albedo"));
    CHECK(set_of(plan, "png", "bsdf").empty());
}

TEST_CASE("bad input names the file and line, the XML element, or the material") {
    Scratch s;
    // Out of range: names the material and the allowed range.
    std::string e = error_of(s.write("eta0.pbrt", "Material \"dielectric\" \"float roughness\" 0.1 "
                                                  "\"float eta\" 0\nShape \"sphere\"\n"));
    CHECK(contains(e, "anonymous-1"));
    CHECK(contains(e, "eta = 0"));
    CHECK(contains(e, "(0, 100]"));
    e = error_of(s.write("ni.xml", "<scene version=\"3.0.0\"><bsdf type=\"roughplastic\" "
                                   "id=\"p\"><float name=\"int_ior\" value=\"0.5\"/></bsdf>"
                                   "<shape type=\"sphere\"><ref id=\"p\"/></shape></scene>"));
    CHECK(contains(e, "material 'p'"));
    CHECK(contains(e, "ni ="));
    // pbrt syntax: file:line:column.
    e = error_of(s.write("str.pbrt", "WorldBegin\nMaterial \"diffuse\n"));
    CHECK(contains(e, "str.pbrt:2:"));
    CHECK(contains(e, "unterminated string"));
    e = error_of(s.write("br.pbrt", "Material \"diffuse\" \"float x\" [ 1 2\n"));
    CHECK(contains(e, "br.pbrt:1:"));
    e = error_of(s.write("nm.pbrt", "\n\nNamedMaterial \"nowhere\"\n"));
    CHECK(contains(e, "nm.pbrt:3:1"));
    CHECK(contains(e, "nowhere"));
    e = error_of(s.write("decl.pbrt", "Material \"diffuse\" \"float\" 1\n"));
    CHECK(contains(e, "decl.pbrt:1:20"));
    e = error_of(s.write("inc.pbrt", "Include \"nothere.pbrt\"\n"));
    CHECK(contains(e, "nothere.pbrt"));
    // Mitsuba: XML errors with a line, substitution and refs with the element path.
    e = error_of(s.write("bad.xml", "<scene version=\"3.0.0\">\n<bsdf type=\"diffuse\">\n</scene>\n"));
    CHECK(contains(e, "bad.xml:3"));
    e = error_of(s.write("sub.xml", "<scene version=\"3.0.0\"><bsdf type=\"roughdielectric\" "
                                    "id=\"g\"><float name=\"alpha\" value=\"$nope\"/></bsdf></scene>"));
    CHECK(contains(e, "scene/bsdf[0]/float[0]"));
    CHECK(contains(e, "$nope"));
    e = error_of(s.write("ref.xml", "<scene version=\"3.0.0\"><shape type=\"sphere\"><ref "
                                    "id=\"ghost\"/></shape></scene>"));
    CHECK(contains(e, "scene/shape[0]/ref[0]"));
    e = error_of(s.write("ior.xml", "<scene version=\"3.0.0\"><bsdf type=\"roughdielectric\" "
                                    "id=\"g\"><string name=\"int_ior\" value=\"unobtainium\"/>"
                                    "</bsdf><shape type=\"sphere\"><ref id=\"g\"/></shape></scene>"));
    CHECK(contains(e, "unobtainium"));
    // brdftab lists: unknown parameter, bad option, duplicate name.
    e = error_of(s.write("m.toml", "[[material]]\nname = \"a\"\nmodel = \"oren-nayar\"\nsigmaa = 3\n"));
    CHECK(contains(e, "m.toml:4:"));
    CHECK(contains(e, "sigmaa"));
    e = error_of(s.write("o.toml", "[[material]]\nname = \"a\"\nmodel = \"micrograin\"\ngrain = \"gold\"\n"));
    CHECK(contains(e, "gold"));
    CHECK(contains(e, "diffuse, dielectric, conductor"));
    e = error_of(s.write("d.toml", "[[material]]\nname = \"a\"\nmodel = \"micrograin\"\n"
                                   "[[material]]\nname = \"a\"\nmodel = \"micrograin\"\n"));
    CHECK(contains(e, "used twice"));
    e = error_of(s.write("x.obj", "o\n"));
    CHECK(contains(e, "--format"));
    // Unknown material types are not errors.
    CHECK(error_of(s.write("u.pbrt", "Material \"hair\"\nShape \"sphere\"\n")) == "(no error)");
}

TEST_CASE("anisotropic roughness: pbrt-v4 coateddiffuse maps to alpha_x / alpha_y, the rest is unsupported") {
    const ScenePlan plan = plan_of("anisotropic.pbrt");
    // pbrt-v4 remaps u and v separately: alpha = sqrt(roughness).
    const MappedMaterial& lac = by_name(plan, "brushed-lacquer");
    CHECK(lac.status == MaterialStatus::Tabulated);
    CHECK(lac.model == "interfaced-lambertian");
    CHECK(lac.parameters.at("alpha_x") == doctest::Approx(0.1).epsilon(1e-15));
    CHECK(lac.parameters.at("alpha_y") == doctest::Approx(0.4).epsilon(1e-15));
    CHECK(lac.parameters.count("alpha") == 0);
    const MappedMaterial& raw = by_name(plan, "brushed-raw");
    CHECK(raw.parameters.at("alpha_x") == 0.1);
    CHECK(raw.parameters.at("alpha_y") == 0.4);
    // u = v: the isotropic alpha.
    const MappedMaterial& even = by_name(plan, "even-lacquer");
    CHECK(even.parameters.at("alpha") == doctest::Approx(0.2).epsilon(1e-15));
    CHECK(even.parameters.count("alpha_x") == 0);
    const MappedMaterial& glass = by_name(plan, "brushed-glass");
    CHECK(glass.status == MaterialStatus::Unsupported);
    CHECK(glass.reason.find("isotropic") != std::string::npos);
    // The anisotropic sets have both azimuths; the isotropic one phi_d.
    const std::string aniso_set = set_of(plan, "brushed-lacquer", "bsdf");
    // sqrt(0.01) and sqrt(0.16) round to the doubles 0.1 and 0.4: one table.
    CHECK(aniso_set == set_of(plan, "brushed-raw", "bsdf"));
    CHECK(aniso_set != set_of(plan, "even-lacquer", "bsdf"));
    for (const SceneTableSet& set : plan.sets) {
        const Spec spec = parse_spec_string(set.spec_text, set.id);
        const bool anisotropic = set.id == aniso_set || set.id == set_of(plan, "brushed-lacquer", "albedo");
        CAPTURE(set.spec_text);
        std::set<std::string> axes;
        for (const Axis& a : spec.tables.front().axes) axes.insert(a.name);
        if (anisotropic) {
            CHECK(axes.count("phi_i") == 1);
            CHECK(axes.count("phi_d") == 0);
            CHECK(axes.count("phi_o") == (set.purpose == "bsdf" ? 1 : 0));
        } else {
            CHECK(axes.count("phi_i") == 0);
        }
    }
    const ScenePlan mi = plan_of("anisotropic.xml");
    CHECK(by_name(mi, "brushed-glass").status == MaterialStatus::Unsupported);
    CHECK(by_name(mi, "brushed-glass").reason.find("isotropic") != std::string::npos);
    CHECK(by_name(mi, "even-glass").status == MaterialStatus::Tabulated);
    CHECK(by_name(mi, "even-glass").parameters.at("alpha") == 0.2);
    CHECK(by_name(mi, "brushed-plastic").status == MaterialStatus::Unsupported);
    CHECK(by_name(mi, "brushed-plastic").reason.find("not parameters of Mitsuba's roughplastic") !=
          std::string::npos);
}

TEST_CASE("closed forms stay closed: rough dielectrics get albedo tables only, coatings a body") {
    // Mitsuba 3 glass (Beckmann, alpha 0.1, water) and a pbrt-v4 glass and
    // coating: the dielectric BSDFs are Walter et al.'s closed forms, the
    // coating's specular lobe is one too.
    Scratch s;
    const std::string xml = s.write(
        "glass.xml",
        "<scene version=\"3.0.0\"><bsdf type=\"roughdielectric\" id=\"glass\">"
        "<float name=\"alpha\" value=\"0.1\"/><float name=\"int_ior\" value=\"1.333\"/></bsdf>"
        "<shape type=\"sphere\"><ref id=\"glass\"/></shape></scene>");
    for (ScenePurpose purpose : {ScenePurpose::Bsdf, ScenePurpose::All, ScenePurpose::Albedo}) {
        ScenePlanSettings settings;
        settings.purpose = purpose;
        const ScenePlan plan = plan_scene_tables(read_scene_materials(xml), settings);
        const MappedMaterial& glass = by_name(plan, "glass");
        CAPTURE(static_cast<int>(purpose));
        REQUIRE(glass.closed_forms.count("bsdf") == 1);
        CHECK(set_of(plan, "glass", "bsdf").empty());
        for (const SceneTableSet& set : plan.sets) CHECK(set.purpose == "albedo");
        if (purpose == ScenePurpose::Bsdf) {
            CHECK(plan.sets.empty());
            CHECK(glass.status == MaterialStatus::NoTableNeeded);
            CHECK(contains(glass.reason, "closed form"));
            // How it maps stays visible, and the manifest keeps the model and
            // parameters a renderer evaluates the closed form with.
            REQUIRE(!glass.notes.empty());
            CHECK(contains(glass.notes.front(), "maps to rough-dielectric"));
            const nlohmann::json man = scene_manifest(plan, xml, "out.h5");
            const nlohmann::json& m = man["materials"][0];
            CHECK(m["status"] == "no-table-needed");
            CHECK(m["table"].is_null());
            CHECK(m["model"] == "rough-dielectric");
            CHECK(m["parameters"]["eta"].get<double>() == doctest::Approx(1.333 / 1.000277));
            CHECK(m["closed_forms"]["bsdf"]["status"] == "no-table-needed");
        } else {
            CHECK(glass.status == MaterialStatus::Tabulated);
            CHECK(!set_of(plan, "glass", "albedo").empty());
        }
    }
    // --tabulate-closed-forms: the BSDF tables come back, and a note says why.
    ScenePlanSettings forced;
    forced.purpose = ScenePurpose::Bsdf;
    forced.tabulate_closed_forms = true;
    const ScenePlan plan = plan_scene_tables(read_scene_materials(xml), forced);
    const MappedMaterial& glass = by_name(plan, "glass");
    CHECK(glass.status == MaterialStatus::Tabulated);
    CHECK(glass.closed_forms.empty());
    CHECK(!set_of(plan, "glass", "bsdf").empty());
    bool noted = false;
    for (const std::string& n : glass.notes) noted = noted || contains(n, "--tabulate-closed-forms");
    CHECK(noted);

    // The coating: its BSDF set holds the body only; the specular part is
    // marked closed, with or without the flag.
    const ScenePlan coat = plan_of("pbrt_v4.pbrt", ScenePurpose::Bsdf);
    const MappedMaterial& red = by_name(coat, "lacquer-red");
    CHECK(red.status == MaterialStatus::Tabulated);
    CHECK(red.closed_forms.count("specular") == 1);
    CHECK(red.closed_forms.count("bsdf") == 0);
    for (const SceneTableSet& set : coat.sets)
        if (set.model == "interfaced-lambertian") CHECK(set.tables == std::vector<std::string>{set.id + "_body"});
    // Oren-Nayar's exact V-cavity BRDF is an integral: tabulated as before.
    const ScenePlan clay = plan_of("mitsuba06.xml", ScenePurpose::Bsdf);
    CHECK(by_name(clay, "clay").closed_forms.empty());
    CHECK(!set_of(clay, "clay", "bsdf").empty());
}
