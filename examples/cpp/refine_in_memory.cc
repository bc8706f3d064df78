// Refines the extrinsics of a rig held in memory, with the installed rigfit package
// (CMakeLists.txt): rigfit's simulator makes the depth images of a 4-camera rig, its true
// extrinsics and perturbed ones; Refine starts from the perturbed ones; EvaluateRig measures
// both against the truth. Your own rig goes in the same structs: a RigCapture with one
// CameraCapture (depth image in metres, intrinsics) per serial, and a PoseMap of
// T_world_camera. Exits with 1 when the refinement did not bring the extrinsics closer to
// the truth.
#include <rigfit/rigfit.h>

#include <cstdio>
#include <string>

namespace {

void PrintErrors(const char* label, const rigfit::RigErrors& e) {
  std::printf("%-20s %10.3f %10.3f %10.2f %10.2f\n", label, e.rms_rotation_rad / rigfit::kDegToRad,
              e.max_rotation_rad / rigfit::kDegToRad, e.rms_translation_m * 1e3,
              e.max_translation_m * 1e3);
}

}  // namespace

int main() {
  rigfit::SimOptions sim;  // a furnished room seen by 4 ZED-like cameras
  sim.width = 320;         // a quarter of the pixels of `rigfit simulate`, for speed
  sim.height = 180;
  // Every camera's initial pose is its true one moved by up to 2 deg of yaw, 0.3 deg of tilt
  // and 5 cm horizontally.
  sim.perturb_yaw_deg = 2.0;
  sim.perturb_tilt_deg = 0.3;
  sim.perturb_xz_m = 0.05;
  const rigfit::SimulatedRig rig = rigfit::SimulateRig(sim);
  std::printf("simulated rig: %zu cameras, %dx%d depth images\n", rig.capture.cameras.size(),
              sim.width, sim.height);

  rigfit::Log log;  // progress dropped, warnings to stderr
  log.sink = [](rigfit::LogLevel level, const std::string& message) {
    if (level == rigfit::LogLevel::kWarning) std::fprintf(stderr, "warning: %s\n", message.c_str());
  };
  const rigfit::RefineResult result =
      rigfit::Refine(rig.capture, rig.init, rigfit::RefineOptions{}, log);
  std::printf("refine: %s\n\n", result.message.c_str());

  const rigfit::RigErrors before = rigfit::EvaluateRig(rig.init, rig.gt);
  const rigfit::RigErrors after = rigfit::EvaluateRig(result.refined, rig.gt);
  std::printf("errors against the truth (gauge-free)\n");
  std::printf("%-20s %10s %10s %10s %10s\n", "", "rot RMS", "rot max", "trans RMS", "trans max");
  std::printf("%-20s %10s %10s %10s %10s\n", "", "deg", "deg", "mm", "mm");
  PrintErrors("before refinement", before);
  PrintErrors("after refinement", after);

  if (!result.success || after.rms_translation_m >= before.rms_translation_m ||
      after.rms_rotation_rad >= before.rms_rotation_rad) {
    std::fprintf(stderr, "refinement did not bring the extrinsics closer to the truth\n");
    return 1;
  }
  return 0;
}
