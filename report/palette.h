// The colour of each camera in every picture of the report and in exported clouds, so that
// a camera has the same colour everywhere.
#pragma once

#include "report/image.h"

namespace rigfit {

/// Number of distinct camera colours; camera indices beyond it repeat them.
inline constexpr int kCameraColors = 20;

/// Colour of the camera at `index` in capture order (serial order). Cameras 0-9 get the
/// Tableau 10 palette (matplotlib's default colour cycle: blue, orange, green, red, purple,
/// brown, pink, grey, olive, cyan), cameras 10-19 the same hues at 55% brightness; from 20
/// on the colours repeat (index modulo kCameraColors).
Rgb CameraColor(int index);

}  // namespace rigfit
