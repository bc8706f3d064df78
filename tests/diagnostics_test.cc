// rig/diagnostics.h: the fit of every candidate pair at given poses. At the true poses of
// a noise-free rig the point-to-plane residuals vanish; moving one camera spoils exactly
// the pairs it belongs to.
#include "rig/diagnostics.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "sim/simulate_rig.h"

namespace rigfit {
namespace {

/// A residual of a noise-free plane matched at the true poses: round-off (m).
constexpr double kExact = 1e-5;

class DiagnosticsTest : public ::testing::Test {
 protected:
  /// A small noise-free rig, leveled at its true poses (the floor is y = 0 there).
  static void SetUpTestSuite() {
    SimOptions sim;
    sim.cameras = 3;
    sim.width = 320;
    sim.height = 180;
    sim.noise = 0.0;
    rig_ = new SimulatedRig(SimulateRig(sim));
    RefineOptions leveling_only;
    leveling_only.run_registration = false;
    const RefineResult leveling = Refine(rig_->capture, rig_->gt, leveling_only);
    diagnostics_ = new DiagnosticRig(PrepareDiagnostics(rig_->capture, leveling, {}, 2));
  }
  static void TearDownTestSuite() {
    delete diagnostics_;
    delete rig_;
  }

  static SimulatedRig* rig_;
  static DiagnosticRig* diagnostics_;
};

SimulatedRig* DiagnosticsTest::rig_ = nullptr;
DiagnosticRig* DiagnosticsTest::diagnostics_ = nullptr;

TEST_F(DiagnosticsTest, NoiseFreeRigFitsExactlyAtTheTruePosesButAtEdges) {
  const std::vector<PairDiagnostics> fits = Diagnose(*diagnostics_, rig_->gt, IcpOptions{}, 2);
  ASSERT_FALSE(fits.empty());
  for (const PairDiagnostics& f : fits) {
    SCOPED_TRACE(diagnostics_->serials[f.a] + " - " + diagnostics_->serials[f.b]);
    EXPECT_GT(f.correspondences, 500);
    EXPECT_EQ(f.residuals_m.size(), static_cast<size_t>(f.correspondences));
    EXPECT_GT(f.inlier_fraction, 0.0);
    EXPECT_LE(f.inlier_fraction, 1.0);
    // Planes fit exactly: almost every residual vanishes. Voxels that straddle an edge (a box
    // corner, a table leg) have centroids off both faces; those few (5-7% here, up to 2 cm) make
    // the RMSE 1.0-1.6 mm on this rig (measured).
    int exact = 0;
    for (double r : f.residuals_m) exact += std::abs(r) < kExact ? 1 : 0;
    EXPECT_GT(exact, 0.9 * f.correspondences);
    EXPECT_LT(f.rmse_m, 0.002);
    double sum_squares = 0.0;
    for (double r : f.residuals_m) sum_squares += r * r;
    EXPECT_NEAR(f.rmse_m, std::sqrt(sum_squares / f.correspondences), 1e-12);
  }
}

TEST_F(DiagnosticsTest, MovingOneCameraSpoilsOnlyItsPairs) {
  const IcpOptions options;
  const std::vector<PairDiagnostics> truth = Diagnose(*diagnostics_, rig_->gt, options, 2);
  PoseMap moved = rig_->gt;
  const std::string serial = diagnostics_->serials[2];
  Vec6 delta;  // 0.3 deg of tilt, 1 deg of yaw, 2 cm across and 1 cm up
  delta << 0.3 * kDegToRad, 1.0 * kDegToRad, 0.0, 0.02, 0.01, 0.0;
  moved[serial] = PosePlus(moved[serial], delta);
  const std::vector<PairDiagnostics> after = Diagnose(*diagnostics_, moved, options, 2);
  ASSERT_EQ(after.size(), truth.size());
  int spoiled = 0;
  for (size_t k = 0; k < truth.size(); ++k) {
    SCOPED_TRACE(diagnostics_->serials[truth[k].a] + " - " + diagnostics_->serials[truth[k].b]);
    if (truth[k].a == 2 || truth[k].b == 2) {
      ++spoiled;
      EXPECT_GT(after[k].rmse_m, 3.0 * truth[k].rmse_m);
      EXPECT_LT(after[k].inlier_fraction, truth[k].inlier_fraction);
    } else {
      EXPECT_EQ(after[k].rmse_m, truth[k].rmse_m);
      EXPECT_EQ(after[k].correspondences, truth[k].correspondences);
    }
  }
  EXPECT_GT(spoiled, 0);
}

TEST_F(DiagnosticsTest, AHorizontalSlideShowsInTheOffFloorResiduals) {
  // 2 cm along the floor (across both horizontal axes, so that walls and box faces of either
  // orientation see it): the floor's residuals stay zero, the walls' and boxes' do not, so
  // the off-floor RMSE grows more than the RMSE of all correspondences.
  const IcpOptions options;
  const std::vector<PairDiagnostics> truth = Diagnose(*diagnostics_, rig_->gt, options, 2);
  PoseMap moved = rig_->gt;
  moved[diagnostics_->serials[2]].translation() += Vec3(0.02, 0.0, 0.02);
  const std::vector<PairDiagnostics> after = Diagnose(*diagnostics_, moved, options, 2);
  int slid = 0;
  for (size_t k = 0; k < truth.size(); ++k) {
    SCOPED_TRACE(diagnostics_->serials[truth[k].a] + " - " + diagnostics_->serials[truth[k].b]);
    EXPECT_GT(truth[k].off_floor_correspondences, 50);
    EXPECT_LT(truth[k].off_floor_correspondences, truth[k].correspondences / 2);
    EXPECT_LT(truth[k].off_floor_rmse_m, 0.004);
    if (truth[k].a != 2 && truth[k].b != 2) continue;
    ++slid;
    EXPECT_GT(after[k].off_floor_rmse_m, 0.008);
    // The floor's unchanged residuals dilute the RMSE of all correspondences (by 1.2-1.7
    // times here, where noise-free floors fit exactly; on noisy depth far more).
    EXPECT_GT(after[k].off_floor_rmse_m / truth[k].off_floor_rmse_m,
              1.1 * after[k].rmse_m / truth[k].rmse_m);
  }
  EXPECT_GT(slid, 0);
}

TEST_F(DiagnosticsTest, ResultDoesNotDependOnTheThreads) {
  const std::vector<PairDiagnostics> one = Diagnose(*diagnostics_, rig_->init, IcpOptions{}, 1);
  const std::vector<PairDiagnostics> two = Diagnose(*diagnostics_, rig_->init, IcpOptions{}, 2);
  ASSERT_EQ(one.size(), two.size());
  for (size_t k = 0; k < one.size(); ++k) EXPECT_EQ(one[k].residuals_m, two[k].residuals_m);
}

// PointResiduals: one value per band point, each the smallest |r| of that point's
// correspondences, so that every finite one is among Diagnose's residuals; at the true poses of
// the noise-free rig they vanish where Diagnose's do, moving a camera makes its points' larger.
TEST_F(DiagnosticsTest, PointResidualsAreTheSmallestOfEachPointsCorrespondences) {
  const IcpOptions options;
  const std::vector<std::vector<float>> truth = PointResiduals(*diagnostics_, rig_->gt, options, 2);
  ASSERT_EQ(truth.size(), diagnostics_->bands.size());
  std::vector<double> pooled;
  for (const PairDiagnostics& d : Diagnose(*diagnostics_, rig_->gt, options, 2)) {
    pooled.insert(pooled.end(), d.residuals_m.begin(), d.residuals_m.end());
  }
  int finite = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    ASSERT_EQ(truth[i].size(), diagnostics_->bands[i].levels[0].points.size());
    for (float r : truth[i]) {
      if (!std::isfinite(r)) continue;
      ++finite;
      const bool found = std::any_of(pooled.begin(), pooled.end(),
                                     [&](double q) { return static_cast<float>(q) == r; });
      EXPECT_TRUE(found) << r;
    }
  }
  EXPECT_GT(finite, 1000);
  EXPECT_LE(finite, static_cast<int>(pooled.size()));

  PoseMap moved = rig_->gt;
  Vec6 delta;  // 0.5 deg of tilt, 1 cm up
  delta << 0.5 * kDegToRad, 0.0, 0.0, 0.0, 0.01, 0.0;
  moved[diagnostics_->serials[2]] = PosePlus(moved[diagnostics_->serials[2]], delta);
  const auto mean_abs = [](const std::vector<float>& rs) {
    double sum = 0.0;
    int n = 0;
    for (float r : rs) {
      if (std::isfinite(r)) sum += std::abs(r), ++n;
    }
    return n > 0 ? sum / n : 0.0;
  };
  const std::vector<std::vector<float>> after = PointResiduals(*diagnostics_, moved, options, 2);
  // Measured: a mean |r| of 0.26 mm at the truth (the rig's edges), 11.2 mm moved; the
  // bound asks for 20 times, half the measured ratio of 42.
  EXPECT_GT(mean_abs(after[2]), 20.0 * mean_abs(truth[2]));
  EXPECT_EQ(after[0].size(), truth[0].size());
}

TEST_F(DiagnosticsTest, PairsAndBandsFollowTheCapture) {
  ASSERT_EQ(diagnostics_->serials.size(), rig_->capture.cameras.size());
  ASSERT_EQ(diagnostics_->bands.size(), rig_->capture.cameras.size());
  for (size_t i = 0; i < diagnostics_->serials.size(); ++i) {
    EXPECT_EQ(diagnostics_->serials[i], rig_->capture.cameras[i].serial);
    ASSERT_EQ(diagnostics_->bands[i].levels.size(), 1u);
    EXPECT_DOUBLE_EQ(diagnostics_->bands[i].levels[0].voxel_size, IcpOptions{}.voxel_size);
    // The band: every point within [-band_below, band_height] at the leveled pose.
    const RegionOptions region;
    for (const Vec3& p : diagnostics_->bands[i].levels[0].points) {
      const double y = (rig_->gt.at(diagnostics_->serials[i]) * p).y();
      EXPECT_GE(y, -region.band_below - 0.02);  // voxel centroids: within a voxel
      EXPECT_LE(y, region.band_height + 0.02);
    }
  }
}

}  // namespace
}  // namespace rigfit
