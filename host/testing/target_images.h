// Rendered images of calibration targets for the tests of calibration (host/calib/detect):
// the simulator's target renderer and sensor model. Test-only, like everything in host/testing:
// calibration's libraries and mfns-calib never include or link the simulator; its tests reach
// it through this folder alone.
#pragma once

#include "host/core/target.h"                  // IWYU pragma: export
#include "host/sim/render/sensor.h"            // IWYU pragma: export
#include "host/sim/render/target_renderer.h"  // IWYU pragma: export
