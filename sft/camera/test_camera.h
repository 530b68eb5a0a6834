// The camera of the solver's unit tests: 320 by 240 pixels, a 58 degree
// horizontal field of view (fx = fy = 288), centred.
#ifndef POLYFIT_SFT_CAMERA_TEST_CAMERA_H_
#define POLYFIT_SFT_CAMERA_TEST_CAMERA_H_

#include "sft/camera/pinhole_camera.h"

namespace polyfit {

inline PinholeCamera TestCamera() {
  PinholeCamera camera;
  camera.fx = camera.fy = 288.0;
  camera.cx = 159.5;
  camera.cy = 119.5;
  camera.width = 320;
  camera.height = 240;
  return camera;
}

}  // namespace polyfit

#endif  // POLYFIT_SFT_CAMERA_TEST_CAMERA_H_
