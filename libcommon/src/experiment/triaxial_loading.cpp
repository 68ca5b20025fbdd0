// A synthetic series' loading states from fdemrun's triaxial test of the exact grains.
#include "graintwin/experiment/triaxial_loading.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <mutex>
#include <numbers>

#include "graintwin/core/error.hpp"
#include "graintwin/core/interrupt.hpp"
#include "graintwin/core/interval.hpp"
#include "graintwin/fdem/scene.hpp"
#include "graintwin/fdem/stages_run.hpp"
#include "graintwin/mesh/ellipsoid_grain.hpp"
#include "graintwin/mesh/gmsh_adapter.hpp"
#include "graintwin/mesh/tet_mesh.hpp"
#include "graintwin/mesh/twin.hpp"

namespace graintwin::experiment {

namespace {

// The scans' strains as the test's: shearing to the largest, frames at the others above 0 (the test
// takes a frame at the start of shearing, strain 0, and at its end anyway).
void set_strains(fdem::TriaxialSpec& spec, const std::vector<double>& strains) {
  const double target = *std::max_element(strains.begin(), strains.end());
  std::vector<double> inner;
  for (double s : strains)
    if (s > 0.0 && s < target) inner.push_back(s);
  std::sort(inner.begin(), inner.end());
  inner.erase(std::unique(inner.begin(), inner.end()), inner.end());
  spec.target_axial_strain = target;
  spec.frame_strains = inner;
}

// The frame of the results taken nearest each asked strain (frames before shearing have none).
std::vector<std::size_t> frames_at(const std::vector<fdem::ResultsFrame>& frames, const std::vector<double>& strains,
                                   const std::filesystem::path& results) {
  std::vector<std::size_t> at;
  for (double s : strains) {
    std::size_t best = frames.size();
    for (std::size_t f = 0; f < frames.size(); ++f)
      if (std::isfinite(frames[f].axial_strain) &&
          (best == frames.size() || std::abs(frames[f].axial_strain - s) < std::abs(frames[best].axial_strain - s)))
        best = f;
    if (best == frames.size())
      throw DataError(results.string() + " holds no frame taken while shearing; the triaxial test did not reach its shearing");
    at.push_back(best);
  }
  return at;
}

// The last row at or before `step` (rows are booked every few steps).
std::size_t row_at(const std::vector<std::uint64_t>& steps, std::uint64_t step) {
  const auto it = std::upper_bound(steps.begin(), steps.end(), step);
  return it == steps.begin() ? 0 : static_cast<std::size_t>(it - steps.begin() - 1);
}

}  // namespace

void check_loading_scene(const std::filesystem::path& scene, const synth::Container& container, double membrane_thickness) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(scene, ec))
    throw UsageError("--triaxial-scene " + scene.string() +
                     " is not a readable file; give a triaxial scene such as pipelines/scenes/triaxial.toml");
  // The scene is read over a model with the sample but no grain yet: every table is checked.
  auto sample_only = std::make_shared<fdem::Model>();
  sample_only->sample = fdem::SampleCylinder{Eigen::Vector2d::Zero(), container.radius, 0.0, container.height, membrane_thickness};
  const fdem::Scene s = fdem::read_scene(scene, std::shared_ptr<const fdem::Model>(sample_only));
  if (!s.triaxial)
    throw UsageError(scene.string() + " has no [triaxial] table; give a triaxial scene such as pipelines/scenes/triaxial.toml");
}

void check_loading_inputs(const synth::SeriesParams& series) {
  using synth::GrainShape;
  const GrainShape shape = series.grains.shape;
  if (shape == GrainShape::angular || shape == GrainShape::library)
    throw UsageError("--loading simulated needs grains whose SH surface is the grain (sphere, ellipsoid or sand); "
                     "angular and library grains are SH fits, so the simulation would not move the grains the scans show");
  if (series.container.kind != synth::Container::Kind::cylinder)
    throw UsageError("--loading simulated runs a triaxial test: give --container cylinder");
  if (*std::max_element(series.strains.begin(), series.strains.end()) <= 0.0)
    throw UsageError("--loading simulated shears the sample: give --strains with a value above 0");
}

std::vector<shape::GrainShape> body_shapes(const synth::GrainSet& grains) {
  std::vector<shape::GrainShape> out(grains.tables.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    shape::GrainShape& g = out[i];
    g.label = static_cast<std::uint32_t>(i + 1);
    shape::set_form(g, grains.stats[i]);
    g.sh_degree = grains.sh_degree;
    g.coeffs = grains.coeffs_body.row(static_cast<Eigen::Index>(i)).transpose();
  }
  return out;
}

fdem::Model exact_grains_model(const synth::GrainSet& grains, const std::vector<synth::PackedGrain>& packed,
                               const synth::Container& container, const TriaxialLoadingParams& params,
                               const std::function<void()>& grain_done) {
  const std::vector<shape::GrainShape> shapes = body_shapes(grains);
  mesh::TwinGrains twin;
  for (const shape::GrainShape& g : shapes) {
    twin.shapes.push_back(&g);
    twin.label.push_back(g.label);
    twin.source_label.push_back(g.label);
  }
  twin.poses = packed;
  mesh::GrainMeshOptions options;
  options.order = 1;  // the grains are rigid: their meshes give surface and inertia, not elasticity
  options.size = params.size;
  options.cut_at_neighbours = false;
  mesh::GmshWorkers workers(mesh::GmshWorkers::useful_count(omp_get_max_threads(), shapes.size()));
  options.workers = &workers;
  const mesh::ShSurfaceBasis basis(params.surface_subdivisions, grains.sh_degree);
  const std::vector<mesh::GrainMeshResult> results = mesh::mesh_twin_grains(twin, basis, nullptr, options, grain_done);
  mesh::TwinModel model = mesh::assemble_twin(twin, results);
  const fdem::SampleCylinder sample =
      mesh::twin_sample(model.model, params.membrane_thickness, &container, nullptr, nullptr).cylinder;
  model.model.sample = sample;
  model.model.platens = mesh::end_platens(sample, params.platen_friction);
  return std::move(model.model);
}

std::function<double(double theta, double z)> membrane_surface(const std::vector<double>& ball_centres,
                                                               const Eigen::Vector2d& axis_xy, double ball_radius) {
  const std::size_t balls = ball_centres.size() / 3;
  if (balls == 0 || !(ball_radius > 0.0)) throw UsageError("membrane_surface: give ball centres and a positive ball radius");
  double z_lo = HUGE_VAL, z_hi = -HUGE_VAL, mean_radius = 0.0;
  std::vector<double> theta(balls), rho(balls);
  for (std::size_t b = 0; b < balls; ++b) {
    const double z = ball_centres[3 * b + 2], dx = ball_centres[3 * b] - axis_xy.x(), dy = ball_centres[3 * b + 1] - axis_xy.y();
    z_lo = std::min(z_lo, z), z_hi = std::max(z_hi, z);
    theta[b] = std::atan2(dy, dx);
    rho[b] = std::hypot(dx, dy);
    mean_radius += rho[b] / static_cast<double>(balls);
  }
  // Bins two balls wide and two high: about four balls each, fine enough to follow the membrane
  // into the hollows between grains a few balls across.
  const double bin = 4.0 * ball_radius;
  const std::size_t n_theta = std::max<std::size_t>(8, static_cast<std::size_t>(std::round(2.0 * std::numbers::pi * mean_radius / bin)));
  const std::size_t n_z = std::max<std::size_t>(1, static_cast<std::size_t>(std::round((z_hi - z_lo) / bin)));
  const double dz = (z_hi - z_lo) / static_cast<double>(n_z), dtheta = 2.0 * std::numbers::pi / static_cast<double>(n_theta);
  std::vector<double> sum(n_theta * n_z, 0.0), count(n_theta * n_z, 0.0);
  for (std::size_t b = 0; b < balls; ++b) {
    const std::size_t i = std::min(n_theta - 1, static_cast<std::size_t>((theta[b] + std::numbers::pi) / dtheta));
    const std::size_t k = dz > 0.0 ? std::min(n_z - 1, static_cast<std::size_t>((ball_centres[3 * b + 2] - z_lo) / dz)) : 0;
    sum[k * n_theta + i] += rho[b] - ball_radius;
    count[k * n_theta + i] += 1.0;
  }
  // Bins no ball fell in (the lattice sheared over them) take their filled neighbours' mean.
  std::vector<double> r(sum.size());
  for (std::size_t c = 0; c < r.size(); ++c) r[c] = count[c] > 0.0 ? sum[c] / count[c] : std::nan("");
  for (bool missing = true; missing;) {
    missing = false;
    std::vector<double> next = r;
    for (std::size_t k = 0; k < n_z; ++k)
      for (std::size_t i = 0; i < n_theta; ++i) {
        if (!std::isnan(r[k * n_theta + i])) continue;
        double total = 0.0, n = 0.0;
        for (const auto& [dk, di] : {std::pair{-1, 0}, {1, 0}, {0, -1}, {0, 1}}) {
          const long kk = static_cast<long>(k) + dk;
          if (kk < 0 || kk >= static_cast<long>(n_z)) continue;
          const double v = r[static_cast<std::size_t>(kk) * n_theta + (i + n_theta + di) % n_theta];
          if (!std::isnan(v)) total += v, n += 1.0;
        }
        if (n > 0.0) next[k * n_theta + i] = total / n;
        else missing = true;
      }
    r = std::move(next);
  }
  // Bilinear between the bins' centres, periodic in theta, constant beyond the end rings in z.
  return [r, n_theta, n_z, dtheta, dz, z_lo](double t, double z) {
    double u = (t + std::numbers::pi) / dtheta - 0.5;
    u -= std::floor(u / static_cast<double>(n_theta)) * static_cast<double>(n_theta);
    const std::size_t i0 = std::min(n_theta - 1, static_cast<std::size_t>(u)), i1 = (i0 + 1) % n_theta;
    const double fu = u - static_cast<double>(i0);
    const double v = dz > 0.0 ? std::clamp((z - z_lo) / dz - 0.5, 0.0, static_cast<double>(n_z - 1)) : 0.0;
    const std::size_t k0 = std::min(n_z - 1, static_cast<std::size_t>(v)), k1 = std::min(n_z - 1, k0 + 1);
    const double fv = v - static_cast<double>(k0);
    const auto at = [&](std::size_t k, std::size_t i) { return r[k * n_theta + i]; };
    return (1 - fv) * ((1 - fu) * at(k0, i0) + fu * at(k0, i1)) + fv * ((1 - fu) * at(k1, i0) + fu * at(k1, i1));
  };
}

std::vector<synth::PackedGrain> frame_poses(const std::vector<synth::PackedGrain>& packed,
                                            const std::vector<Eigen::Vector3d>& reference_centroid,
                                            const std::vector<Eigen::Quaterniond>& reference_rotation,
                                            const std::vector<double>& centroid, const std::vector<double>& rotation) {
  const std::size_t n = packed.size();
  if (reference_centroid.size() != n || reference_rotation.size() != n || centroid.size() != 3 * n ||
      rotation.size() != 4 * n)
    throw UsageError("frame_poses: give one reference and one frame pose per grain");
  std::vector<synth::PackedGrain> out(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Quaterniond q(rotation[4 * i], rotation[4 * i + 1], rotation[4 * i + 2], rotation[4 * i + 3]);
    const Eigen::Quaterniond turn = (q.normalized() * reference_rotation[i].normalized().conjugate()).normalized();
    const Eigen::Vector3d c(centroid[3 * i], centroid[3 * i + 1], centroid[3 * i + 2]);
    out[i].position = c + turn * (packed[i].position - reference_centroid[i]);
    out[i].orientation = (turn * packed[i].orientation).normalized();
  }
  return out;
}

std::vector<synth::PairForce> pair_forces(const fdem::ResultsFrame& frame) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, Eigen::Vector3d> sum;
  for (std::size_t c = 0; c < frame.platen.size(); ++c) {
    if (frame.platen[c] >= 0) continue;
    const Eigen::Vector3d f(frame.force[3 * c], frame.force[3 * c + 1], frame.force[3 * c + 2]);
    auto [it, fresh] = sum.try_emplace({frame.pair[2 * c], frame.pair[2 * c + 1]}, f);
    if (!fresh) it->second += f;
  }
  std::vector<synth::PairForce> out;
  out.reserve(sum.size());
  for (const auto& [pair, f] : sum) out.push_back({pair.first, pair.second, f});
  return out;
}

synth::LoadingSimulation triaxial_loading(const TriaxialLoadingParams& params) {
  return [params](const synth::GrainSet& grains, const std::vector<synth::PackedGrain>& packed,
                  const synth::Container& container, const std::vector<double>& strains, const std::filesystem::path& dir,
                  const std::vector<std::string>& history,
                  const std::function<std::function<void(double)>(const std::string&)>& progress) {
    // The exact grains' rigid model, run through the scene's triaxial test.
    auto mesh_progress = progress("meshing the exact grains");
    std::mutex progress_lock;
    std::size_t meshed = 0;
    const std::size_t n = grains.tables.size();
    auto model_in = std::make_shared<fdem::Model>(exact_grains_model(grains, packed, container, params, [&] {
      const std::lock_guard<std::mutex> hold(progress_lock);  // called from the meshing threads
      if (mesh_progress) mesh_progress(static_cast<double>(++meshed) / static_cast<double>(n));
    }));
    mesh_progress = nullptr;  // the display ends here
    throw_if_interrupted();
    fdem::Scene scene = fdem::read_scene(params.scene, std::shared_ptr<const fdem::Model>(model_in));
    set_strains(*scene.triaxial, strains);
    fdem::Model model = fdem::build_model(scene, mesh::append_ellipsoid_grain);
    const std::string where = params.scene.string();
    const fdem::RunStart start = fdem::start_run(scene, model, where);
    fdem::Solver& solver = *start.solver;
    const fdem::RunSchedule schedule = fdem::schedule_run(scene, solver, where);
    // The step a replicate perturbs ([run] time_step a little below it): the results may be dropped.
    spdlog::info("simulated loading: time step {:.6g} s", schedule.dt);
    std::vector<Eigen::Vector3d> reference_centroid(n);
    std::vector<Eigen::Quaterniond> reference_rotation(n);
    for (std::size_t g = 0; g < n; ++g)
      reference_centroid[g] = solver.grain_centroid(g), reference_rotation[g] = solver.grain_rotation(g);

    const std::filesystem::path results = dir / "simulation.h5";
    std::ifstream scene_file(params.scene, std::ios::binary);
    const std::string scene_text((std::istreambuf_iterator<char>(scene_file)), std::istreambuf_iterator<char>());
    nlohmann::json parameters = fdem::run_parameters(scene, where, scene_text, start, schedule, omp_get_max_threads(), "");
    fdem::ResultsWriter writer(results, solver, parameters.dump());
    // Progress: the consolidations run until they settle, so only shearing's share of its strain is
    // known; until it starts, a status line every half minute says how far they are from settling.
    std::function<void(double)> shear_progress;  // made when shearing starts: its clock starts there
    std::string phase;
    bool shearing = false;
    double shear_start_height = 0.0;
    Interval status(kStatusLineSeconds);
    fdem::TriaxialRunHooks hooks;
    hooks.phase = [&](const std::string& name, std::size_t) {
      spdlog::info("simulated loading: {}", name);
      phase = name;
      shearing = phase == "shearing";
      if (shearing) shear_progress = progress("simulated triaxial test, shearing");
      status = Interval(kStatusLineSeconds);
    };
    hooks.step = [&](const fdem::TriaxialMeasure& m, const fdem::StepReport& r, const fdem::TriaxialRunProgress& at) {
      if (shearing && shear_start_height == 0.0) shear_start_height = m.height;
      if (shearing && shear_progress && solver.step_count() % 256 == 0)
        shear_progress(std::clamp(std::log(shear_start_height / m.height) / scene.triaxial->target_axial_strain, 0.0, 1.0));
      if (!shearing && status.due())
        spdlog::info("simulated loading: {}, {} in: {}", phase, format_duration(status.elapsed()),
                     fdem::consolidation_status(*scene.triaxial, m, r, at.procedure));
      throw_if_interrupted();
    };
    const std::optional<fdem::TriaxialRunSummary> summary =
        fdem::run_triaxial_scene(solver, scene, schedule, 0, &writer, hooks, [](const fdem::TriaxialRunProgress&) {});
    shear_progress = nullptr;
    parameters["triaxial"] = fdem::triaxial_summary_json(*summary);
    parameters["steps"] = solver.step_count();
    writer.set_parameters(parameters.dump());
    writer.finish(history);
    spdlog::info("simulated loading: {} + {} consolidation and {} shearing steps, {} membrane balls", summary->consolidation_steps,
                 summary->membrane_steps, summary->shear_steps, summary->membrane_balls);

    // The frames at the scans' strains, back as states.
    std::vector<fdem::ResultsFrame> frames(fdem::results_frame_count(results));
    for (std::size_t f = 0; f < frames.size(); ++f) frames[f] = fdem::read_results_frame(results, f);
    const fdem::ResultsSeries rows = fdem::read_results_series(results);
    const fdem::TriaxialSeries curve = fdem::read_triaxial_series(results);
    const std::vector<std::size_t> at = frames_at(frames, strains, results);
    const std::size_t platens = rows.step.empty() ? 0 : rows.platen_position.size() / (3 * rows.step.size());
    synth::SimulatedLoading loaded;
    std::vector<synth::LoadedState>& states = loaded.states;
    states.resize(strains.size());
    for (std::size_t k = 0; k < strains.size(); ++k) {
      const fdem::ResultsFrame& frame = frames[at[k]];
      synth::LoadedState& s = states[k];
      s.simulated = true;
      s.axial_strain = frame.axial_strain;
      s.poses = frame_poses(packed, reference_centroid, reference_rotation, frame.centroid, frame.rotation);
      const std::size_t row = row_at(rows.step, frame.step);
      s.base_z = HUGE_VAL, s.top_z = -HUGE_VAL;
      for (std::size_t p = 0; p < platens; ++p) {
        const double z = rows.platen_position[3 * (row * platens + p) + 2];
        s.base_z = std::min(s.base_z, z), s.top_z = std::max(s.top_z, z);
      }
      if (frame.membrane_position.empty())
        throw UsageError(params.scene.string() + ": the triaxial test's frames carry no membrane; give [triaxial] "
                         "boundary = \"membrane\"");
      s.membrane_inner_radius = membrane_surface(frame.membrane_position, model.sample->axis_xy, summary->ball_radius);
      s.forces = pair_forces(frame);
      s.max_overlap = 0.0;
      for (std::size_t c = 0; c < frame.platen.size(); ++c)
        if (frame.platen[c] < 0) s.max_overlap = std::max(s.max_overlap, frame.overlap[c]);
      s.contact_tolerance = 0.0;  // a simulated pair touches when it carries a force (synth/series)
      const std::size_t r = row_at(curve.step, frame.step);
      if (!curve.step.empty()) s.stress_ratio = curve.stress_ratio[r], s.volumetric_strain = curve.volumetric_strain[r];
      if (std::abs(s.axial_strain - strains[k]) > 0.05 * std::max(strains[k], 1e-3))
        spdlog::warn("scan {}: the nearest frame is at strain {:.4g}, not {:.4g}", k, s.axial_strain, strains[k]);
    }
    // The curve of the truth: the rows from the start of shearing (before it, no axial strain).
    for (std::size_t r = 0; r < curve.step.size(); ++r)
      if (std::isfinite(curve.axial_strain[r])) {
        loaded.curve.axial_strain.push_back(curve.axial_strain[r]);
        loaded.curve.stress_ratio.push_back(curve.stress_ratio[r]);
        loaded.curve.volumetric_strain.push_back(curve.volumetric_strain[r]);
      }
    if (!params.keep_results) std::filesystem::remove(results);
    return loaded;
  };
}

}  // namespace graintwin::experiment
