// rigfit's public C++ API in one header: #include <rigfit/rigfit.h> and link rigfit::rigfit
// (find_package(rigfit), examples/cpp/). Everything is in namespace rigfit.
//
// Rig pipeline: a RigCapture (core/types.h: one depth image or point cloud per camera, by
// serial) and initial extrinsics, a PoseMap of T_world_camera (core/pose.h), go into Refine
// with RefineOptions (rig/refine.h, options/refine_options.h; LoadConfig reads them from YAML); the
// RefineResult holds the refined poses and what was and was not applied. ReadCapture and
// WriteCapture (io/capture_h5.h) and ReadExtrinsics and WriteExtrinsics (io/extrinsics_json.h)
// read and write the files of the CLI; SimulateRig (sim/simulate_rig.h) makes a rig with its
// true and perturbed extrinsics; EvaluateRig (core/evaluate.h) measures extrinsics against the
// truth, free of the pose of the rig as a whole; Compare (rig/compare.h) runs the three ways to
// refine a rig side by side.
//
// RGB-D pipeline: an RgbdSequence (core/rgbd.h) from OpenRgbdSequence (io/rgbd_sequence.h) or
// a SimulatedSequence (sim/simulate_sequence.h) is tracked by RunOdometry (rgbd/odometry.h) or
// RunSlam (rgbd/slam.h: frame-to-model, into a SurfelMap), their loops closed by
// CloseOdometryLoops / CloseSlamLoops (rgbd/loop_closure.h); EvaluateTrajectory
// (core/trajectory.h) gives ATE and RPE, ReadTumTrajectory and WriteTumTrajectory
// (io/trajectory_tum.h) the TUM files.
//
// Options as a command line or a script names them: CheckSimOptions (sim/simulate_rig.h),
// ApplyTrackingSettings (rgbd/tracking_options.h) and CheckTrajectoryEvaluationSettings
// (core/trajectory.h) check the settings of `rigfit simulate`, `track` and
// `evaluate-trajectory`; a bad value throws SettingError (core/setting_error.h), which names
// the setting by its key and lets each front end spell it (a flag, a keyword).
//
// Errors (core/errors.h): I/O throws InputError naming the file and field; the solvers return
// a result with `success` and `message` instead of throwing on bad geometry. Progress and
// warnings go to a Log (core/log.h), silent when default-constructed.
#pragma once

#include "core/errors.h"
#include "core/evaluate.h"
#include "core/log.h"
#include "core/pose.h"
#include "core/rgbd.h"
#include "core/trajectory.h"
#include "core/types.h"
#include "io/capture_h5.h"
#include "io/config_yaml.h"
#include "io/extrinsics_json.h"
#include "io/rgbd_sequence.h"
#include "io/trajectory_tum.h"
#include "options/refine_options.h"
#include "rgbd/loop_closure.h"
#include "rgbd/odometry.h"
#include "rgbd/slam.h"
#include "rgbd/tracking_options.h"
#include "rig/compare.h"
#include "rig/refine.h"
#include "sim/simulate_rig.h"
#include "sim/simulate_sequence.h"
