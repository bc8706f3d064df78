#include "io/pose_matrix.h"

#include <Eigen/SVD>
#include <sstream>

#include "core/errors.h"

namespace rigfit {
namespace {

/// Rotation blocks with ||R^T R - I|| (max norm) above this are not rotations (formats.md).
/// Real pose files are printed with limited precision: 7-Scenes' pose.txt files are
/// orthonormal to about 3e-4, hand-edited matrices to about 1e-4.
constexpr double kMaxRotationDeviation = 1e-3;
/// Up to this deviation R is a rotation to printing precision and is taken as it is
/// (projected onto SO(3) silently, a change below 1e-6); between the two it is projected
/// and a warning is reported.
constexpr double kSilentRotationDeviation = 1e-6;
/// Up to this deviation R is a rotation to double round-off: kept bit for bit, so that files
/// rigfit writes read back exactly.
constexpr double kRoundOffDeviation = 1e-12;
/// Tolerance on the last row [0, 0, 0, 1].
constexpr double kLastRowTolerance = 1e-9;

std::string FormatDouble(double x) {
  std::ostringstream s;
  s.precision(3);
  s << x;
  return s.str();
}

}  // namespace

Pose PoseFromMatrix(const Eigen::Matrix4d& M, const std::string& field,
                    std::vector<std::string>* warnings) {
  if ((M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > kLastRowTolerance) {
    throw InputError(field + ": last row must be [0, 0, 0, 1]");
  }
  Mat3 R = M.topLeftCorner<3, 3>();
  const double deviation = (R.transpose() * R - Mat3::Identity()).cwiseAbs().maxCoeff();
  const double det = R.determinant();
  if (deviation > kMaxRotationDeviation || det <= 0.0) {
    throw InputError(
        field + ": rotation block is not a rotation (||R^T R - I|| = " + FormatDouble(deviation) +
        ", det = " + FormatDouble(det) + "; tolerance 1e-3)");
  }
  if (deviation > kRoundOffDeviation) {
    // Nearest rotation in the Frobenius norm: R = U S V^T -> U V^T (det > 0 checked above).
    const Eigen::JacobiSVD<Mat3> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
    R = svd.matrixU() * svd.matrixV().transpose();
  }
  if (deviation > kSilentRotationDeviation) {
    warnings->push_back(field + ": rotation re-orthonormalised (||R^T R - I|| = " +
                        FormatDouble(deviation) + ", above 1e-6)");
  }
  Pose T = Pose::Identity();
  T.linear() = R;
  T.translation() = M.topRightCorner<3, 1>();
  return T;
}

}  // namespace rigfit
