// The paper's Table 5 (navigation on the turntable about Zt, Newton iteration, beacons matched
// by hand) as published: reference/paper-tables.yaml, table5_navigation. Table 3's sigma
// lives with the rest of the published rig in common/rig/paper_rig.h. paper_numbers_test
// checks both against the YAML.
#pragma once

#include <array>

namespace mfns::host {

struct PublishedAxis {
  double mean;
  double std;
};

// Order of kPoseAxes: x_mm, y_mm, z_mm, roll_deg, pitch_deg, yaw_deg.
inline constexpr std::array<PublishedAxis, 6> kPaperTable5 = {{
    {-0.0553, 1.6043},
    {0.0275, 1.6108},
    {-0.0669, 1.8292},
    {-0.0030, 0.1541},
    {-0.0192, 0.1497},
    {0.0066, 0.1729},
}};

}  // namespace mfns::host
