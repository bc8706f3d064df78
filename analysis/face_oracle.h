// The face oracle (issue 33): the surface bundle's estimator told the truth it lacks, which
// pixel lies on which face, to find what holds the bundle back. Each camera's pixels of the
// near-floor band (analysis/crlb.h RigFacePixels: labelled on the noise-free capture at the
// true poses) are read from the noisy capture, grouped by their true face, and the poses and
// the faces' planes solved from a start with the inverse-depth residual: per (camera, face)
// cluster with independent pixels (residuals/plane_cluster.h), or per camera over all its faces
// with the correlated noise whitened (residuals/camera_planes.h; analysis/correlated_noise.h
// WhitenedGram). A pixel whose measured inverse depth is more than gate_sigmas sigma_w from its
// face's (the noise-free depth: stereo matching's fattened edges and mismatches) is left out too.
// The reference camera is held at its pose in `start` (give it its true pose: the floor's normal is
// held at +Y); no gravity prior, no start prior.
#pragma once

#include <string>
#include <vector>

#include "analysis/correlated_noise.h"
#include "analysis/crlb.h"
#include "core/pose.h"
#include "core/types.h"

namespace rigfit {

struct FaceOracleOptions {
  double depth_noise = 0.0;  ///< k of sigma_z = k z^2 (sigma_w = k)
  /// share > 0: each camera's pixels whitened by this model; 0: independent pixels.
  CorrelatedNoiseModel correlated;
  double gate_sigmas = 5.0;
};

struct FaceOracleResult {
  bool ok = false;
  std::string message;
  PoseMap poses;
  int pixels = 0;  ///< used (labelled, counted by BoundFaces, valid in the noisy capture, gated)
  int gated = 0;   ///< left out by the gate
};

/// The poses solved from `start` on `noisy` with the true faces of `labelled` (noise-free
/// pixels, RigFacePixels) and their planes `faces` (the starting planes: the truth).
FaceOracleResult SolveWithTrueFaces(const RigCapture& noisy,
                                    const std::vector<FacePixels>& labelled,
                                    const std::vector<PlanarFace>& faces, const PoseMap& start,
                                    const std::string& reference, const FaceOracleOptions& options);

}  // namespace rigfit
