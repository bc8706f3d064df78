#include "io/trajectory_tum.h"

#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>

#include "core/errors.h"
#include "io/atomic_file.h"
#include "io/text_table.h"

namespace rigfit {
namespace {

/// A quaternion norm this far from 1 is no rounding of a unit quaternion.
constexpr double kQuaternionNormTolerance = 1e-2;

}  // namespace

Trajectory ReadTumTrajectory(const std::string& path) {
  Trajectory trajectory;
  for (const TextRow& row : ReadTextRows(path)) {
    const std::string where = LineWhere(path, row.line);
    double v[8];
    int count = 0;
    for (const std::string& token : row.fields) {
      if (count == 8) throw InputError(where + ": more than 8 values");
      v[count++] = ParseFiniteNumber(token, where);
    }
    const std::string& stamp = row.fields.front();
    if (count != 8) {
      throw InputError(where + ": expected 8 values (timestamp tx ty tz qx qy qz qw), got " +
                       std::to_string(count));
    }
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    if (std::abs(q.norm() - 1.0) > kQuaternionNormTolerance) {
      throw InputError(where + ": quaternion norm " + std::to_string(q.norm()) +
                       " is not 1 (qx qy qz qw)");
    }
    if (!trajectory.timestamps.empty() && !(v[0] > trajectory.timestamps.back())) {
      throw InputError(where + ": timestamp " + stamp + " does not increase");
    }
    Pose T = Pose::Identity();
    T.linear() = q.normalized().toRotationMatrix();
    T.translation() = Vec3(v[1], v[2], v[3]);
    trajectory.timestamps.push_back(v[0]);
    trajectory.poses.push_back(T);
  }
  if (trajectory.poses.empty()) throw InputError(path + ": no poses");
  return trajectory;
}

void WriteTumTrajectory(const std::string& path, const Trajectory& trajectory,
                        const std::vector<std::string>& comments) {
  std::ostringstream out;
  out << "# timestamp tx ty tz qx qy qz qw\n";
  for (const std::string& comment : comments) out << "# " << comment << '\n';
  out << std::setprecision(17);
  for (size_t k = 0; k < trajectory.poses.size(); ++k) {
    const Pose& T = trajectory.poses[k];
    const Eigen::Quaterniond q(T.linear());
    const Vec3 t = T.translation();
    out << trajectory.timestamps[k] << ' ' << t.x() << ' ' << t.y() << ' ' << t.z() << ' ' << q.x()
        << ' ' << q.y() << ' ' << q.z() << ' ' << q.w() << '\n';
  }
  WriteTextFileAtomically(path, out.str());
}

}  // namespace rigfit
