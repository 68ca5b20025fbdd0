// kind=labels files (segment/labels_file): the checks made on the grain table without reading the
// label image, as the report makes them on a run's files.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "graintwin/core/error.hpp"
#include "graintwin/io/h5file.hpp"
#include "graintwin/segment/labels.hpp"
#include "graintwin/segment/labels_file.hpp"
#include "support/phantoms.hpp"
#include "support/run_tool.hpp"

using namespace graintwin;
using namespace graintwin::segment;

TEST(LabelsFile, TheGrainTableIsCheckedWithoutTheImage) {
  test::TempDir dir;
  LabelsFile c;
  c.labels = test::label_balls({20, 20, 20}, {{6.0, 6.0, 6.0, 4.0}, {13.0, 13.0, 13.0, 4.0}});
  c.grains = grain_table(c.labels);
  c.parameters_json = "{}";
  write_labels_file(dir / "good.h5", c, {"phantom"});
  EXPECT_NO_THROW(check_labels_tables(io::H5File::open(dir / "good.h5")));

  // A NaN volume, or an infinite centroid, is no value ct2labels writes.
  LabelsFile nan_volume = c;
  nan_volume.grains[1].volume_m3 = std::numeric_limits<double>::quiet_NaN();
  write_labels_file(dir / "nan.h5", nan_volume, {"phantom"});
  EXPECT_THROW(check_labels_tables(io::H5File::open(dir / "nan.h5")), DataError);
  LabelsFile far = c;
  far.grains[0].centroid_xyz[2] = std::numeric_limits<double>::infinity();
  write_labels_file(dir / "far.h5", far, {"phantom"});
  try {
    check_labels_tables(io::H5File::open(dir / "far.h5"));
    FAIL() << "an infinite centroid passed";
  } catch (const DataError& e) {
    EXPECT_NE(e.message().find("/grains/centroid"), std::string::npos) << e.message();
    EXPECT_NE(e.message().find("ct2labels"), std::string::npos) << e.message();
  }
}
