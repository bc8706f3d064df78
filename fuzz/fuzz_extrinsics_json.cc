// Fuzz target: the JSON extrinsics loader (io/extrinsics_json.h ParseExtrinsics) on arbitrary
// text. Rejecting the text with InputError is correct behaviour; anything else (another
// exception, a crash, a sanitizer report, a leak, a hang) is a finding.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/errors.h"
#include "io/extrinsics_json.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const rigfit::ExtrinsicsDocument document = rigfit::ParseExtrinsics(text, "fuzz.json");
    // Every pose accepted is a rigid transform that WriteExtrinsics can write.
    for (const auto& [serial, T] : document.poses) {
      const rigfit::Mat3 R = T.linear();
      if (!T.matrix().allFinite() || (R.transpose() * R - rigfit::Mat3::Identity()).norm() > 1e-9 ||
          R.determinant() <= 0) {
        __builtin_trap();
      }
      (void)rigfit::PoseToJson(T).dump();
    }
  } catch (const rigfit::InputError&) {
  }
  return 0;
}
