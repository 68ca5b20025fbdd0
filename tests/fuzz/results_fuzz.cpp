// Fuzz target: kind=fdem_results files (fdem/results_file.cpp) as tracks2micro, fdem2forces and
// report (micro/simulation.cpp) and fdemrun's most_loaded rule (fdem/grain_selection.cpp) read them,
// structure-aware (h5_mutator.hpp).
#include "fuzz_support.hpp"
#include "graintwin/fdem/grain_selection.hpp"
#include "graintwin/fdem/results_file.hpp"
#include "graintwin/micro/simulation.hpp"
#include "h5_mutator.hpp"

GRAINTWIN_FUZZ_TARGET(results) {
  graintwin::fuzz::fuzz_h5_reader("fdem_results readers", graintwin::fuzz::base_file("results.h5"), data, size,
                                  [](const std::filesystem::path& p) {
                                    namespace micro = graintwin::micro;
                                    graintwin::fdem::read_results_series(p);
                                    graintwin::fdem::read_triaxial_series(p);
                                    const micro::SimulationGrains grains = micro::read_simulation_grains(p);
                                    std::vector<double> times;
                                    micro::simulation_states(p, grains, &times);
                                    graintwin::fdem::read_results_grains(p);
                                    const std::size_t frames = graintwin::fdem::results_frame_count(p);
                                    for (std::size_t k = 0; k < frames; ++k) {
                                      const auto frame = graintwin::fdem::read_results_frame(p, k);
                                      micro::frame_contacts(frame, grains, p, k);
                                      micro::frame_centroids(frame, grains, p, k);
                                      graintwin::fdem::mean_stress_by_label(p, k);  // fdemrun's most_loaded rule
                                    }
                                    micro::simulation_branch_roses(p, {0, frames - 1}, 6, 12);
                                  });
}
