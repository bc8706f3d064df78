// Trajectories in the TUM RGB-D benchmark's text format: one pose per line,
// `timestamp tx ty tz qx qy qz qw` (seconds; T_world_camera with the translation in metres and
// the rotation as a unit quaternion), lines starting with '#' and blank lines ignored.
#pragma once

#include <string>
#include <vector>

#include "core/trajectory.h"

namespace rigfit {

/// Reads a TUM trajectory. Throws InputError naming the file and the line for: an unreadable
/// file, a line without exactly 8 numbers, a non-finite value, a quaternion whose norm is not
/// within 1e-2 of 1 (files print 4-6 digits: within that it is normalised), a timestamp that
/// does not increase, and a file without poses.
Trajectory ReadTumTrajectory(const std::string& path);

/// Writes a TUM trajectory (every number with enough digits to read back exactly), atomically.
/// Each line of `comments` (e.g. the run's counts of failed and recovered frames) is written
/// after the column header as a '#' line, which readers skip.
void WriteTumTrajectory(const std::string& path, const Trajectory& trajectory,
                        const std::vector<std::string>& comments = {});

}  // namespace rigfit
