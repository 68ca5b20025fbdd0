// Fuzz target: kind=tracks files (track/tracks_file.cpp), structure-aware (h5_mutator.hpp).
#include "fuzz_support.hpp"
#include "graintwin/track/tracks_file.hpp"
#include "h5_mutator.hpp"

GRAINTWIN_FUZZ_TARGET(tracks) {
  graintwin::fuzz::fuzz_h5_reader("tracks readers", graintwin::fuzz::base_file("tracks.h5"), data, size,
                                  [](const std::filesystem::path& p) {
                                    graintwin::track::read_tracked_centroids(p);
                                    graintwin::track::read_tracks_file(p);
                                  });
}
