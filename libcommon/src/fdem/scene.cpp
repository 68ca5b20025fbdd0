// fdemrun scene files: one parse function per scene table, called in order by read_scene; the
// checked TOML access they read with is in scene_table.hpp, the model a scene builds in
// scene_model.cpp.
#include "graintwin/fdem/scene.hpp"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <set>
#include <string>

#include "graintwin/core/error.hpp"
#include "graintwin/core/message.hpp"
#include "graintwin/core/strings.hpp"
#include "graintwin/fdem/grain_selection.hpp"
#include "graintwin/fdem/model_file.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "scene_table.hpp"

namespace graintwin::fdem {
namespace {

using detail::Table;
using detail::tables;

GrainKind parse_kind(const Table& t) {
  const std::string k = t.text("kind", enum_name(kGrainKindNames, GrainKind::tet4));
  if (const std::optional<GrainKind> kind = find_enum(kGrainKindNames, k)) return *kind;
  t.fail("kind '" + excerpt(k) + "' is unknown; use rigid, tet4 or tet10");
}

/// The [triaxial] table (docs/fdem_triaxial.md).
TriaxialSpec parse_triaxial(const Table& t, const std::optional<SampleCylinder>& sample) {
  TriaxialSpec spec;
  TriaxialOptions& o = spec.options;
  const std::string boundary = t.text("boundary", "membrane");
  if (boundary != "membrane" && boundary != "wall") t.fail("boundary '" + excerpt(boundary) + "' is unknown; use membrane or wall");
  spec.membrane = boundary == "membrane";
  o.confining_pressure = t.positive("confining_pressure", o.confining_pressure);
  o.membrane.young = t.positive("membrane_young", o.membrane.young);
  o.membrane.poisson = t.number("membrane_poisson", o.membrane.poisson);
  const double thickness = sample && sample->membrane_thickness > 0 ? sample->membrane_thickness : o.membrane.thickness;
  o.membrane.thickness = t.positive("membrane_thickness", thickness);
  o.membrane.density = t.positive("membrane_density", o.membrane.density);
  try {
    bond_stiffness(o.membrane);
  } catch (const UsageError& e) {
    t.fail(e.message());
  }
  o.ball_radius = t.non_negative("ball_radius", 0);
  o.membrane_friction = t.non_negative("membrane_friction", o.membrane_friction);
  o.servo_inertial_number = t.positive("servo_inertial_number", o.servo_inertial_number);
  o.stress_tolerance = t.positive("stress_tolerance", o.stress_tolerance);
  if (o.stress_tolerance >= 0.5) t.fail("stress_tolerance must be a small fraction of the confining pressure, e.g. 0.01");
  spec.shear_inertial_number = t.positive("shear_inertial_number", spec.shear_inertial_number);
  spec.strain_rate = t.non_negative("strain_rate", 0);
  if (t.has("strain_rate") && t.has("shear_inertial_number"))
    t.fail("strain_rate and shear_inertial_number both set the shearing rate; keep one");
  spec.target_axial_strain = t.positive("target_axial_strain", spec.target_axial_strain);
  if (spec.target_axial_strain >= 1) t.fail("target_axial_strain is a log strain and must be below 1, e.g. 0.1");
  spec.shear_ramp_strain = t.non_negative("shear_ramp_strain", spec.shear_ramp_strain);
  if (spec.shear_ramp_strain >= spec.target_axial_strain)
    t.fail("shear_ramp_strain (default 5e-3) must be below target_axial_strain: the platens reach full speed within it; set it to a tenth of the target, for example");
  if (t.has("frame_strains")) {
    const toml::array* a = t.raw()["frame_strains"].as_array();
    const std::string usage = "frame_strains must be an ascending array of axial strains in (0, target_axial_strain), e.g. [0.03, 0.06]";
    if (!a) t.fail(usage);
    for (const toml::node& item : *a) {
      const auto e = item.value<double>();
      if (!e || !(*e > 0) || !(*e < spec.target_axial_strain) || (!spec.frame_strains.empty() && *e <= spec.frame_strains.back()))
        t.fail(usage);
      spec.frame_strains.push_back(*e);
    }
  }
  const auto count = [&](const char* key, std::size_t fallback) {
    const double v = t.positive(key, static_cast<double>(fallback));
    if (v != std::floor(v)) t.fail(std::string(key) + " must be a whole number of steps");
    return static_cast<std::size_t>(v);
  };
  spec.consolidation_steps = count("consolidation_steps", spec.consolidation_steps);
  spec.pressure_ramp_steps = count("pressure_ramp_steps", spec.pressure_ramp_steps);
  return spec;
}

/// A whole number in [0, 2^32) under `key`, or `fallback` when it is absent.
std::size_t whole(const Table& t, const char* key, std::size_t fallback) {
  const double v = t.non_negative(key, static_cast<double>(fallback));
  if (v != std::floor(v) || v >= 4294967296.0) t.fail(std::string(key) + " must be a whole number, e.g. 0");
  return static_cast<std::size_t>(v);
}

/// An input file of a rule, relative to the scene's folder; it must exist.
std::filesystem::path rule_file(const Table& t, const std::filesystem::path& scene, const std::string& what) {
  if (!t.has("file")) t.fail("file is missing: the " + what);
  const std::filesystem::path file = scene.parent_path() / t.text("file", "");
  if (!std::filesystem::exists(file))
    t.fail("file " + file.string() + " does not exist (paths are relative to the scene's folder); give the " + what);
  return file;
}

/// The [model.deformable] table: the rule that picks the model file's deformable grains (each rule
/// takes only its own keys) and the grains it picks, checked before any heavy work.
DeformableSelection parse_deformable(const toml::table& table, const std::string& where, const std::filesystem::path& scene,
                                     const Model& model, const std::string& model_name, const D2minByLabel& d2min) {
  const toml::node* rule_node = table.get("rule");
  if (!rule_node) throw UsageError(where + ": rule is missing: pick the deformable grains by labels, box, d2min or most_loaded");
  const std::string rule = rule_node->value<std::string>().value_or("");
  const Table t = [&] {  // each rule takes only its own keys
    if (rule == "labels") return Table(table, where, {"rule", "labels"});
    if (rule == "box") return Table(table, where, {"rule", "min", "max"});
    if (rule == "d2min") return Table(table, where, {"rule", "file", "state", "increment", "above"});
    if (rule == "most_loaded") return Table(table, where, {"rule", "file", "frame", "count", "share"});
    throw UsageError(where + ": rule '" + excerpt(rule) + "' is unknown; use labels, box, d2min or most_loaded");
  }();
  DeformableSelection out;
  const auto wrap = [&](const auto& read) {  // a reader's refusal, named under this table
    try {
      return read();
    } catch (const UsageError& e) {
      t.fail(e.message());
    }
  };
  if (rule == "labels") {
    const toml::array* a = table.get("labels") ? table.get("labels")->as_array() : nullptr;
    const std::string usage = "labels must be a non-empty array of grain labels, e.g. [3, 7, 12]";
    if (!a || a->empty()) t.fail(usage);
    std::vector<std::uint32_t> labels;
    for (const toml::node& item : *a) {
      const auto v = item.value<double>();
      if (!v || *v < 1 || *v != std::floor(*v) || *v >= 4294967296.0) t.fail(usage);
      labels.push_back(static_cast<std::uint32_t>(*v));
    }
    std::vector<std::uint32_t> unknown;
    out.grains = grains_with_labels(model, labels, unknown);
    if (!unknown.empty())
      t.fail(fmt::format("label {} is not a grain of {}{}; give labels of its grains", unknown.front(), model_name,
                         unknown.size() > 1 ? fmt::format(" (nor are {} more)", unknown.size() - 1) : std::string()));
    out.rule = fmt::format("labels ({} given)", labels.size());
  } else if (rule == "box") {
    if (!t.has("min") || !t.has("max")) t.fail("a box needs min and max, its corners in m, e.g. min = [-1e-3, -1e-3, 0]");
    const Eigen::Vector3d lo = t.vector("min", Eigen::Vector3d::Zero()), hi = t.vector("max", Eigen::Vector3d::Zero());
    if (!(lo.array() < hi.array()).all()) t.fail("min must lie below max on every axis");
    out.grains = grains_in_box(model, lo, hi);
    out.rule = fmt::format("centroids in the box [{:g}, {:g}, {:g}] to [{:g}, {:g}, {:g}] m", lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
  } else if (rule == "d2min") {
    const std::filesystem::path micro = rule_file(t, scene, "kind=micro file of tracks2micro");
    if (!t.has("increment")) t.fail("increment is missing: the row of the micro file's /increments whose D2min picks the grains");
    if (!t.has("above")) t.fail("above is missing: the D2min / d50^2 above which a grain deforms, e.g. 0.01");
    const std::size_t state = whole(t, "state", 0), increment = whole(t, "increment", 0);
    const double above = t.non_negative("above", 0);
    if (!d2min) t.fail("this program cannot read kind=micro files; run the scene with fdemrun");
    const std::map<std::uint32_t, double> values = wrap([&] { return d2min(micro, state, increment); });
    out.grains = grains_above(model, values, above);
    out.rule = fmt::format("D2min / d50^2 above {:g} over increment {} of {} (labels of its state {})", above, increment,
                           micro.filename().string(), state);
  } else {
    const std::filesystem::path results = rule_file(t, scene, "kind=fdem_results file of an earlier run, e.g. a rigid twin's consolidation");
    if (t.has("count") == t.has("share")) t.fail("give count (a number of grains) or share (of the model file's grains), one of them");
    const std::size_t frames = wrap([&] { return results_frame_count(results); });
    if (frames == 0) t.fail(results.string() + " holds no frame; give the results of a run that saved frames");
    const std::size_t frame = whole(t, "frame", frames - 1);
    if (frame >= frames) t.fail(fmt::format("frame {} is not in {} (it holds {}); give a frame below {}", frame, results.string(), frames, frames));
    std::size_t count = 0;
    if (t.has("count")) {
      count = whole(t, "count", 0);
      if (count < 1 || count > model.grains.size())
        t.fail(fmt::format("count must lie in [1, {}], the model file's grains (got {})", model.grains.size(), count));
    } else {
      const double share = t.number("share", 0);
      if (!(share > 0 && share <= 1)) t.fail(fmt::format("share must lie in (0, 1] (got {:g})", share));
      count = std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(share * static_cast<double>(model.grains.size()))));
    }
    const std::map<std::uint32_t, double> stress = wrap([&] { return mean_stress_by_label(results, frame); });
    std::size_t missing = 0;
    for (const Grain& g : model.grains) missing += stress.count(g.label) == 0;
    if (missing > 0)
      t.fail(fmt::format("{} lacks {} of the {} grains of {}; give the results of a run of the same model file", results.string(),
                         missing, model.grains.size(), model_name));
    out.grains = grains_highest(model, stress, count);
    out.rule = fmt::format("the {} grains of highest mean stress in frame {} of {}", count, frame, results.filename().string());
  }
  if (out.grains.empty()) t.fail("the rule picks no grain of " + model_name + "; widen it (or leave [model.deformable] out)");
  return out;
}

/// The [model] table (or --model, or a model given in memory): the shapes2mesh model and its sample cylinder.
void parse_model(toml::table& root, const Table& top, const std::filesystem::path& path,
                 const std::filesystem::path& model_file, const std::shared_ptr<const Model>& given,
                 const D2minByLabel& d2min, const std::string& file, Scene& s) {
  if ((!model_file.empty() || given) && !root.contains("model")) root.insert("model", toml::table{});
  if (const toml::table* model = root["model"].as_table()) {
    const Table t(*model, file + ": [model]", {"file", "kind", "deformable"});
    ModelSource source;
    if (given) {
      source.model = given;
    } else {
      if (!t.has("file") && model_file.empty()) t.fail("file is missing: the kind=fdem_model .h5 of shapes2mesh");
      source.path = model_file.empty() ? path.parent_path() / t.text("file", "") : model_file;
      if (!std::filesystem::exists(source.path))
        t.fail("model file " + source.path.string() + " does not exist" +
               (model_file.empty() ? " (paths are relative to the scene's folder)" : ""));
      source.model = std::make_shared<const Model>(read_model_file(source.path));
    }
    if (t.has("kind")) {
      source.kind = parse_kind(t);
      if (*source.kind == GrainKind::tet10)
        t.fail("kind may be \"rigid\" or \"tet4\" (10-node elements split into 4-node ones on their nodes); for 10-node grains "
               "leave it out to keep the file's kinds, from a mesh of shapes2mesh --order 2");
    }
    if (t.has("deformable")) {
      const toml::table* deformable = (*model)["deformable"].as_table();
      if (!deformable) t.fail("deformable must be a [model.deformable] table");
      if (source.kind) t.fail("kind and [model.deformable] contradict each other; keep one");
      const std::string name = source.path.empty() ? std::string("the model") : source.path.filename().string();
      source.deformable = parse_deformable(*deformable, file + ": [model.deformable]", path, *source.model, name, d2min);
    }
    s.sample = source.model->sample;
    s.model = std::move(source);
  } else if (top.has("model")) {
    top.fail("model must be a [model] table");
  }
}

/// The [sample] table: the sample cylinder, over the model file's.
void parse_sample(const toml::table& root, const Table& top, const std::string& file, Scene& s) {
  if (const toml::table* sample = root["sample"].as_table()) {
    const Table t(*sample, file + ": [sample]", {"axis_xy", "radius", "z_min", "z_max", "membrane_thickness"});
    SampleCylinder c = s.sample.value_or(SampleCylinder{});
    const Eigen::Vector3d axis = t.vector("axis_xy", Eigen::Vector3d(c.axis_xy.x(), c.axis_xy.y(), 0));
    c.axis_xy = axis.head<2>();
    c.radius = t.positive("radius", c.radius > 0 ? c.radius : -1);
    c.z_min = t.number("z_min", c.z_min);
    c.z_max = t.number("z_max", c.z_max);
    if (!(c.z_max > c.z_min)) t.fail("z_max must lie above z_min");
    c.membrane_thickness = t.non_negative("membrane_thickness", c.membrane_thickness);
    s.sample = c;
  } else if (top.has("sample")) {
    top.fail("sample must be a [sample] table");
  }
}

/// A table's local_damping: the share of a node's unbalanced force that opposes its motion, [0, 1).
double local_damping(const Table& t, double fallback) {
  const double v = t.number("local_damping", fallback);
  if (!(v >= 0 && v < 1)) t.fail(fmt::format("local_damping must lie in [0, 1) (a share of the unbalanced force; got {:g})", v));
  return v;
}

/// The [run] table; returns its duration (0 when not given).
double parse_run(const toml::table& root, const Table& top, const std::string& file, Scene& s) {
  double duration = 0;
  if (const toml::table* run = root["run"].as_table()) {
    const Table r(*run, file + ": [run]",
                  {"duration", "time_step", "time_step_fraction", "element_safety", "rigid_contact_nodes", "gravity", "damping",
                   "stiffness_damping", "local_damping", "contact", "frame_interval", "series_interval", "checkpoint_interval",
                   "overlap_tolerance", "relax_overlaps", "keep_initial_overlaps", "mass_scaled_share", "element_step_target",
                   "max_added_mass_share", "max_steps", "rigid_stress", "deformable_integration"});
    duration = r.non_negative("duration", 0);
    s.time_step = r.non_negative("time_step", 0);
    s.time_step_fraction = r.positive("time_step_fraction", 1.0);
    if (s.time_step_fraction > 1) r.fail("time_step_fraction must be at most 1 (a fraction of the stable limit)");
    if (s.time_step > 0 && s.time_step_fraction != 1.0)
      r.fail("give time_step or time_step_fraction, not both (the fraction scales the automatic step)");
    s.element_safety = r.positive("element_safety", 0.8);
    if (s.element_safety > 1) r.fail("element_safety must be at most 1 (a fraction of the critical step)");
    s.rigid_contact_nodes = r.number("rigid_contact_nodes", s.rigid_contact_nodes);
    if (!(s.rigid_contact_nodes >= 1)) r.fail("rigid_contact_nodes must be at least 1");
    s.gravity = r.vector("gravity", Eigen::Vector3d::Zero());
    s.damping = r.non_negative("damping", 0);
    s.stiffness_damping = r.non_negative("stiffness_damping", 0);
    s.local_damping = local_damping(r, 0);
    const std::string rigid_stress = r.text("rigid_stress", "love_weber");
    if (rigid_stress != "love_weber" && rigid_stress != "elastostatic")
      r.fail("rigid_stress must be \"love_weber\" (each rigid grain's stress from its contact forces) or \"elastostatic\" "
             "(also its elements' static stresses), not \"" + rigid_stress + "\"");
    s.elastostatic_stress = rigid_stress == "elastostatic";
    const std::string integration = r.text("deformable_integration", "explicit");
    if (integration != "explicit" && integration != "implicit")
      r.fail("deformable_integration must be \"explicit\" (central differences at the element step) or \"implicit\" "
             "(each deformable grain implicit in its corotated frame, at the contact step), not \"" + integration + "\"");
    s.implicit_grains = integration == "implicit";
    s.contact = r.flag("contact", true);
    s.frame_interval = r.non_negative("frame_interval", 0);
    s.series_interval = r.non_negative("series_interval", 0);
    s.checkpoint_interval = r.non_negative("checkpoint_interval", 0);
    s.overlaps.tolerance = r.number("overlap_tolerance", s.overlaps.tolerance);
    if (!(s.overlaps.tolerance >= 1e-3 && s.overlaps.tolerance <= 0.5))
      r.fail(fmt::format("overlap_tolerance must lie in [0.001, 0.5] (a fraction of the smaller grain's equivalent diameter; "
                         "got {:g})",
                         s.overlaps.tolerance));
    s.overlaps.relax = r.flag("relax_overlaps", false);
    s.overlaps.keep = r.flag("keep_initial_overlaps", false);
    s.mass_scaled_share = r.number("mass_scaled_share", 0);
    if (!(s.mass_scaled_share >= 0 && s.mass_scaled_share <= 0.2))
      r.fail(fmt::format("mass_scaled_share must lie in [0, 0.2] (the share of grains whose density may be scaled; got {:g})",
                         s.mass_scaled_share));
    s.element_step_target = r.non_negative("element_step_target", 0);
    s.max_added_mass_share = r.number("max_added_mass_share", s.max_added_mass_share);
    if (!(s.max_added_mass_share > 0 && s.max_added_mass_share <= 1))
      r.fail(fmt::format("max_added_mass_share must lie in (0, 1] (the mass selective mass scaling may add, a share of the "
                         "grains' mass; got {:g})",
                         s.max_added_mass_share));
    if (r.has("max_added_mass_share") && !(s.element_step_target > 0))
      r.fail("max_added_mass_share bounds selective mass scaling, which element_step_target asks for; give both or neither");
    s.max_steps = r.number("max_steps", s.max_steps);
    // Step counts stay exact in a double and an int64 below 1e15.
    if (!(s.max_steps >= 1 && s.max_steps <= 1e15))
      r.fail(fmt::format("max_steps must lie in [1, 1e+15] (got {:g})", s.max_steps));
  } else if (top.has("run")) {
    top.fail("run must be a [run] table");
  }
  return duration;
}

/// The [[materials]] tables, over the model file's materials of the same name; returns every
/// material's name, in order.
std::vector<std::string> parse_materials(const toml::table& root, const std::string& file, Scene& s) {
  std::vector<std::string> material_names;
  if (s.model)
    for (const Material& mat : s.model->model->materials) s.materials.push_back(mat), material_names.push_back(mat.name);
  const std::size_t model_materials = s.materials.size();
  for (const toml::table* m : tables(root, "materials", file)) {
    const Table t(*m, file + ": [[materials]] " + std::to_string(s.materials.size() + 1),
                  {"name", "density", "young", "poisson", "friction", "normal_penalty", "tangential_penalty", "damping_ratio",
                   "penalty_per_size", "penalty_element_size"});
    Material mat;
    mat.name = t.text("name", mat.name);
    mat.density = t.number("density", mat.density);
    mat.young = t.number("young", mat.young);
    mat.poisson = t.number("poisson", mat.poisson);
    mat.friction = t.number("friction", mat.friction);
    mat.normal_penalty = t.number("normal_penalty", mat.normal_penalty);
    mat.tangential_penalty = t.number("tangential_penalty", mat.tangential_penalty);
    mat.damping_ratio = t.number("damping_ratio", mat.damping_ratio);
    // The same ranges as a model file's materials (one check for both).
    if (const std::string problem = material_range_problem(mat); !problem.empty()) t.fail(problem);
    SizePenalty size_penalty;
    if (t.has("penalty_per_size")) size_penalty.per_size = t.positive("penalty_per_size", 0.0);
    if (t.has("penalty_element_size")) size_penalty.element_size = t.positive("penalty_element_size", 0.0);
    if (t.has("penalty_per_size") && (t.has("normal_penalty") || t.has("tangential_penalty")))
      t.fail("penalty_per_size sets normal_penalty and tangential_penalty; give one or the others");
    if (t.has("penalty_element_size") && !t.has("penalty_per_size"))
      t.fail("penalty_element_size needs penalty_per_size (p = penalty_per_size x young / penalty_element_size)");
    const auto same = std::find(material_names.begin(), material_names.end(), mat.name);
    const auto index = static_cast<std::size_t>(same - material_names.begin());
    if (same != material_names.end() && index >= model_materials)
      t.fail("material name '" + mat.name + "' is used twice; give each material its own name");
    s.size_penalties.resize(s.materials.size());
    if (same != material_names.end()) {
      s.materials[index] = mat;  // the scene's values replace the model file's material of that name
      s.size_penalties[index] = size_penalty;
    } else {
      material_names.push_back(mat.name);
      s.materials.push_back(mat);
      s.size_penalties.push_back(size_penalty);
    }
  }
  if (s.materials.empty()) s.materials.push_back(Material{}), material_names.push_back(Material{}.name);
  s.size_penalties.resize(s.materials.size());
  return material_names;
}

/// The [[grains]] tables: primitives meshed by fdemrun.
void parse_grains(const toml::table& root, const std::string& file, const std::vector<std::string>& material_names,
                  Scene& s) {
  std::uint32_t first_label = 1;  // primitives are numbered after the model file's labels
  if (s.model)
    for (const Grain& g : s.model->model->grains) first_label = std::max(first_label, g.label + 1);
  for (const toml::table* g : tables(root, "grains", file)) {
    const Table t(*g, file + ": [[grains]] " + std::to_string(s.grains.size() + 1),
                  {"shape", "size", "radius", "semi_axes", "rotation", "position", "element_size", "kind", "material",
                   "label", "velocity", "angular_velocity", "refine_at", "fine_element_size", "size_growth"});
    GrainSpec spec;
    const std::string shape_name = t.text("shape", "box");
    const std::optional<PrimitiveShape> shape = find_enum(kPrimitiveShapeNames, shape_name);
    if (!shape) t.fail("shape '" + excerpt(shape_name) + "' is unknown; use box, sphere or ellipsoid");
    spec.shape = *shape;
    // Each shape takes exactly its own size keys, so a box given a radius is an error, not ignored.
    const auto only = [&](const char* key, std::initializer_list<const char*> others) {
      for (const char* other : others)
        if (t.has(other)) t.fail(std::string(other) + " does not apply to a " + shape_name + "; give " + key);
      if (!t.has(key)) t.fail(std::string(key) + " is missing for the " + shape_name);
    };
    switch (spec.shape) {
      case PrimitiveShape::box:
        only("size", {"radius", "semi_axes", "rotation"});
        spec.size = t.vector("size", Eigen::Vector3d::Zero());
        break;
      case PrimitiveShape::sphere:
        only("radius", {"size", "semi_axes", "rotation"});
        spec.size = Eigen::Vector3d::Constant(t.positive("radius", 0));
        break;
      case PrimitiveShape::ellipsoid: {
        only("semi_axes", {"size", "radius"});
        spec.size = t.vector("semi_axes", Eigen::Vector3d::Zero());
        const Eigen::Vector3d r = t.vector("rotation", Eigen::Vector3d::Zero());
        if (r.norm() > 0) spec.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(r.norm(), r.normalized()));
        break;
      }
    }
    if (!(spec.size.minCoeff() > 0)) t.fail("the " + shape_name + "'s size must be positive in every direction");
    spec.position = t.vector("position", Eigen::Vector3d::Zero());
    // Boxes mesh exactly with one cell across; a curved surface needs a few elements per radius.
    const bool box = spec.shape == PrimitiveShape::box;
    spec.element_size = t.positive("element_size", box ? spec.size.minCoeff() : spec.size.minCoeff() / 2);
    if (spec.size.maxCoeff() / spec.element_size > 200)
      t.fail("element_size is below 1/200 of the grain; give a larger element_size");
    if (t.has("refine_at")) {
      if (box) t.fail("refine_at applies to spheres and ellipsoids; a box is meshed on a regular grid");
      SizeGrading grading;
      grading.points = t.vectors("refine_at");
      if (!t.has("fine_element_size")) t.fail("fine_element_size is missing for refine_at; give the size at the points, e.g. 2e-5");
      grading.fine = t.positive("fine_element_size", 0);
      grading.growth = t.positive("size_growth", grading.growth);
      grading.coarse = spec.element_size;
      try {
        check_size_grading(grading);
      } catch (const UsageError& e) {
        t.fail(e.message() + " (the coarse size is element_size)");
      }
      spec.grading = grading;
    } else if (t.has("fine_element_size") || t.has("size_growth")) {
      t.fail("fine_element_size and size_growth need refine_at, the points where the mesh is finest");
    }
    spec.kind = parse_kind(t);
    const std::string material = t.text("material", material_names.front());
    const auto it = std::find(material_names.begin(), material_names.end(), material);
    if (it == material_names.end()) t.fail("material '" + material + "' is not among the [[materials]]");
    spec.material = static_cast<std::uint32_t>(it - material_names.begin());
    const double label = t.number("label", double(first_label + s.grains.size()));
    if (!(label >= 1 && label < 4294967296.0) || label != std::floor(label)) t.fail("label must be a positive integer");
    spec.label = static_cast<std::uint32_t>(label);
    spec.velocity = t.vector("velocity", Eigen::Vector3d::Zero());
    spec.angular_velocity = t.vector("angular_velocity", Eigen::Vector3d::Zero());
    s.grains.push_back(spec);
  }
}

/// Checks across the model file's grains and the scene's: at least one grain, labels unique, and a
/// grain for every material whose penalty is measured on its grains' meshes.
void check_grains(const std::string& file, const Scene& s) {
  if (s.grains.empty() && !s.model)
    throw UsageError(file + " has no [[grains]] and no [model]; add at least one grain");
  std::set<std::uint32_t> labels;
  if (s.model)
    for (const Grain& g : s.model->model->grains) labels.insert(g.label);
  for (const GrainSpec& g : s.grains)
    if (!labels.insert(g.label).second)
      throw UsageError(file + ": grain label " + std::to_string(g.label) + " is used twice (the model file's labels " +
                       "count too); give each grain its own label");
  // A penalty measured on its grains' meshes needs a grain; say so before any meshing.
  std::vector<char> used(s.materials.size(), 0);
  if (s.model)
    for (const Grain& g : s.model->model->grains) used[g.material] = 1;
  for (const GrainSpec& g : s.grains) used[g.material] = 1;
  for (std::size_t k = 0; k < s.materials.size(); ++k)
    if (s.size_penalties[k].per_size > 0 && !(s.size_penalties[k].element_size > 0) && !used[k])
      throw UsageError(file + ": material '" + s.materials[k].name + "' sets penalty_per_size but no grain uses it; " +
                       "give it penalty_element_size or drop the key");
}

/// The [[platens]] tables, else the model file's platens; returns their names, in order.
std::vector<std::string> parse_platens(const toml::table& root, const std::string& file, Scene& s) {
  std::vector<std::string> platen_names;
  for (const toml::table* p : tables(root, "platens", file)) {
    const Table t(*p, file + ": [[platens]] " + std::to_string(s.platens.size() + 1),
                  {"name", "point", "normal", "friction", "velocity"});
    PlatenSpec spec;
    spec.platen.name = t.text("name", "platen" + std::to_string(s.platens.size() + 1));
    spec.platen.point = t.vector("point", Eigen::Vector3d::Zero());
    const Eigen::Vector3d n = t.vector("normal", Eigen::Vector3d::UnitZ());
    if (!(n.norm() > 0)) t.fail("normal must not be zero");
    spec.platen.normal = n.normalized();
    spec.platen.friction = t.number("friction", 0);
    // The range of a model file's platens (validate_model).
    if (!(spec.platen.friction >= 0 && spec.platen.friction <= 10))
      t.fail(fmt::format("friction must lie in [0, 10] (got {:g})", spec.platen.friction));
    spec.velocity = t.vector("velocity", Eigen::Vector3d::Zero());
    if (std::find(platen_names.begin(), platen_names.end(), spec.platen.name) != platen_names.end())
      t.fail("platen name '" + spec.platen.name + "' is used twice");
    platen_names.push_back(spec.platen.name);
    s.platens.push_back(spec);
  }
  if (s.platens.empty() && s.model)
    for (const Platen& p : s.model->model->platens) {
      s.platens.push_back(PlatenSpec{p, Eigen::Vector3d::Zero()});
      platen_names.push_back(p.name);
    }
  return platen_names;
}

/// The [[stages]] tables.
void parse_stages(const toml::table& root, const std::string& file, const std::vector<std::string>& platen_names,
                  Scene& s) {
  for (const toml::table* st : tables(root, "stages", file)) {
    const Table t(*st, file + ": [[stages]] " + std::to_string(s.stages.size() + 1),
                  {"name", "duration", "damping", "stiffness_damping", "local_damping", "platens"});
    StageSpec spec;
    spec.name = t.text("name", "stage" + std::to_string(s.stages.size() + 1));
    if (!t.has("duration")) t.fail("duration is missing (s)");
    spec.duration = t.positive("duration", 0);
    if (t.has("damping")) spec.damping = t.non_negative("damping", 0);
    if (t.has("stiffness_damping")) spec.stiffness_damping = t.non_negative("stiffness_damping", 0);
    if (t.has("local_damping")) spec.local_damping = local_damping(t, 0);
    spec.platen_velocity.resize(s.platens.size());
    if (t.has("platens")) {
      const toml::table* velocities = t.raw()["platens"].as_table();
      if (!velocities) t.fail("platens must be a table of platen name = [vx, vy, vz] (m/s)");
      for (auto&& [name, value] : *velocities) {
        const auto it = std::find(platen_names.begin(), platen_names.end(), std::string(name.str()));
        if (it == platen_names.end()) t.fail("platen '" + std::string(name.str()) + "' is not among the [[platens]]");
        toml::table one;
        one.insert("velocity", value);
        spec.platen_velocity[static_cast<std::size_t>(it - platen_names.begin())] =
            Table(one, t.where() + " platens", {"velocity"}).vector("velocity", Eigen::Vector3d::Zero());
      }
    }
    s.stages.push_back(spec);
  }
}

/// The [triaxial] table; true when the scene is a triaxial test (which runs its own stages).
bool parse_triaxial_table(const toml::table& root, const Table& top, const std::string& file, double duration, Scene& s) {
  if (const toml::table* triaxial = root["triaxial"].as_table()) {
    const Table t(*triaxial, file + ": [triaxial]",
                  {"boundary", "confining_pressure", "membrane_young", "membrane_poisson", "membrane_thickness",
                   "membrane_density", "ball_radius", "membrane_friction", "servo_inertial_number", "stress_tolerance",
                   "shear_inertial_number", "strain_rate", "target_axial_strain", "shear_ramp_strain", "frame_strains",
                   "consolidation_steps", "pressure_ramp_steps"});
    if (!s.stages.empty() || duration > 0)
      t.fail("a triaxial test runs its own stages (consolidation, membrane, shearing); remove [[stages]] and [run] duration");
    if (!s.sample) t.fail("a triaxial test needs the sample cylinder: take the grains from a shapes2mesh [model] or give [sample]");
    s.triaxial = parse_triaxial(t, s.sample);
    return true;
  } else if (top.has("triaxial")) {
    top.fail("triaxial must be a [triaxial] table");
  }
  return false;
}

/// Without [[stages]], one stage of [run] duration; both set is an error.
void finish_stages(const std::string& file, double duration, Scene& s) {
  if (s.stages.empty()) {
    if (!(duration > 0)) throw UsageError(file + ": give [run] duration (s) or at least one [[stages]] table");
    StageSpec only;
    only.name = "run";
    only.duration = duration;
    only.platen_velocity.resize(s.platens.size());
    s.stages.push_back(only);
  } else if (duration > 0) {
    throw UsageError(file + ": [run] duration and [[stages]] both set the run's length; keep one");
  }
}

/// Selective mass scaling changes the grains' inertia, so it is for quasi-static runs only: a
/// triaxial test (servo-controlled consolidation, shearing at a small inertial number) or stages
/// that all damp the grains.
void check_selective_mass_scaling(const std::string& file, const Scene& s) {
  if (!(s.element_step_target > 0) || s.triaxial) return;
  for (const StageSpec& st : s.stages)
    if (!(st.damping.value_or(s.damping) > 0 || st.stiffness_damping.value_or(s.stiffness_damping) > 0 ||
          st.local_damping.value_or(s.local_damping) > 0))
      throw UsageError(file + ": [run] element_step_target (selective mass scaling) is for quasi-static runs only, a " +
                       "[triaxial] test or stages that all damp the grains, and stage '" + st.name +
                       "' has no damping; give it damping, stiffness_damping or local_damping, or drop element_step_target");
}

/// Implicit grains take mass-proportional damping alone so far, and have no element step for
/// selective mass scaling to lift.
void check_implicit_grains(const std::string& file, const Scene& s) {
  if (!s.implicit_grains) return;
  const std::string why = ": [run] deformable_integration = \"implicit\" takes mass-proportional damping only so far, ";
  if (s.stiffness_damping > 0 || s.local_damping > 0)
    throw UsageError(file + why + "and [run] sets stiffness_damping or local_damping; set them to 0 (or integrate explicitly)");
  for (const StageSpec& st : s.stages)
    if (st.stiffness_damping.value_or(0) > 0 || st.local_damping.value_or(0) > 0)
      throw UsageError(file + why + "and stage '" + st.name +
                       "' sets stiffness_damping or local_damping; set them to 0 (or integrate explicitly)");
  if (s.element_step_target > 0)
    throw UsageError(file + ": [run] element_step_target (selective mass scaling) lifts the element step, which implicit "
                            "grains do not have; drop it or set deformable_integration = \"explicit\"");
}

}  // namespace

bool Scene::has_deformable_grains() const {
  for (const GrainSpec& g : grains)
    if (g.kind != GrainKind::rigid) return true;
  if (!model) return false;
  if (model->deformable) return true;
  if (model->kind) return *model->kind != GrainKind::rigid;
  return std::any_of(model->model->grains.begin(), model->model->grains.end(), [](const Grain& g) { return g.kind != GrainKind::rigid; });
}

double Scene::total_duration() const {
  double t = 0;
  for (const StageSpec& s : stages) t += s.duration;
  return t;
}

double Scene::largest_stiffness_damping() const {
  double beta = stiffness_damping;
  for (const StageSpec& s : stages) beta = std::max(beta, s.stiffness_damping.value_or(stiffness_damping));
  return beta;
}

namespace {
Scene parse_scene(const std::filesystem::path& path, const std::filesystem::path& model_file,
                  const std::shared_ptr<const Model>& given, const D2minByLabel& d2min) {
  const std::string file = path.string();
  toml::table root;
  try {
    root = toml::parse_file(file);
  } catch (const toml::parse_error& e) {
    throw UsageError(file + " line " + std::to_string(e.source().begin.line) + ": " + shorten_quotes(std::string(e.description())) +
                     "; fix the TOML syntax");
  }
  const Table top(root, file, {"run", "model", "sample", "materials", "grains", "platens", "stages", "triaxial"});
  Scene s;
  parse_model(root, top, path, model_file, given, d2min, file, s);
  parse_sample(root, top, file, s);
  const double duration = parse_run(root, top, file, s);
  const std::vector<std::string> material_names = parse_materials(root, file, s);
  parse_grains(root, file, material_names, s);
  check_grains(file, s);
  const std::vector<std::string> platen_names = parse_platens(root, file, s);
  parse_stages(root, file, platen_names, s);
  if (!parse_triaxial_table(root, top, file, duration, s)) finish_stages(file, duration, s);
  check_selective_mass_scaling(file, s);
  check_implicit_grains(file, s);
  return s;
}
}  // namespace

Scene read_scene(const std::filesystem::path& path, const std::filesystem::path& model_file, const D2minByLabel& d2min) {
  return parse_scene(path, model_file, nullptr, d2min);
}

Scene read_scene(const std::filesystem::path& path, std::shared_ptr<const Model> model, const D2minByLabel& d2min) {
  if (!model) throw UsageError("read_scene: give a model");
  return parse_scene(path, {}, model, d2min);
}

}  // namespace graintwin::fdem
