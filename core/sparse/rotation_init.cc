#include "core/sparse/rotation_init.h"

#include <opengv/relative_pose/CentralRelativeAdapter.hpp>
#include <opengv/relative_pose/methods.hpp>
#include <opengv/types.hpp>

namespace dfsm {
namespace {

opengv::bearingVectors_t Bearings(const Eigen::Matrix2Xd& pixels, const CameraModel& camera) {
  opengv::bearingVectors_t bearings;
  bearings.reserve(pixels.cols());
  for (int j = 0; j < pixels.cols(); ++j) {
    const Eigen::Vector2d x_u = camera.PixelToUndistorted(pixels.col(j));
    bearings.push_back(Eigen::Vector3d(x_u.x(), x_u.y(), 1.0).normalized());
  }
  return bearings;
}

}  // namespace

std::vector<Eigen::Matrix3d> EstimateRotations(const FeatureTracks& tracks,
                                               const CameraModel& camera) {
  std::vector<Eigen::Matrix3d> rotations(tracks.num_frames(), Eigen::Matrix3d::Identity());
  const opengv::bearingVectors_t reference = Bearings(tracks.pixels[tracks.reference], camera);
  for (int i = 0; i < tracks.num_frames(); ++i) {
    if (i == tracks.reference || tracks.num_tracks() < 3) continue;
    const opengv::bearingVectors_t frame = Bearings(tracks.pixels[i], camera);
    opengv::relative_pose::CentralRelativeAdapter adapter(reference, frame);
    const opengv::rotation_t ref_from_frame = opengv::relative_pose::rotationOnly(adapter);
    // OpenGV returns the rotation taking frame bearings into the reference
    // (b_ref = R b_i); the contract's R_i goes the other way.
    rotations[i] = ref_from_frame.transpose();
  }
  return rotations;
}

}  // namespace dfsm
