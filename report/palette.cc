#include "report/palette.h"

namespace rigfit {

Rgb CameraColor(int index) {
  static constexpr Rgb kTableau10[] = {
      {31, 119, 180}, {255, 127, 14},  {44, 160, 44},   {214, 39, 40},  {148, 103, 189},
      {140, 86, 75},  {227, 119, 194}, {127, 127, 127}, {188, 189, 34}, {23, 190, 207}};
  constexpr int kBase = sizeof(kTableau10) / sizeof(kTableau10[0]);
  const int i = ((index % kCameraColors) + kCameraColors) % kCameraColors;
  const Rgb base = kTableau10[i % kBase];
  return i < kBase ? base : Mix(kBlack, base, 0.55);
}

}  // namespace rigfit
