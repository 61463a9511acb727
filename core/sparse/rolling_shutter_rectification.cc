#include "core/sparse/rolling_shutter_rectification.h"

#include "core/camera/rolling_shutter.h"
#include "core/sparse/rotation_init.h"

namespace dfsm {

FeatureTracks RectifyRollingShutter(const FeatureTracks& tracks, const CameraModel& camera,
                                    const std::vector<Pose>& poses, double readout,
                                    const std::vector<double>& times) {
  FeatureTracks rectified = tracks;
  const RowPoses rows(poses, readout, camera.height, times);
  for (int i = 0; i < tracks.num_frames(); ++i) {
    for (int j = 0; j < tracks.num_tracks(); ++j) {
      const Eigen::Vector2d pixel = tracks.pixels[i].col(j);
      const Eigen::Vector2d x = camera.PixelToUndistorted(pixel);
      const Eigen::Vector3d ray =
          poses[i].R * rows.At(i, pixel.y()).R.transpose() * Eigen::Vector3d(x.x(), x.y(), 1.0);
      if (const auto moved = camera.UndistortedToPixel(ray.head<2>() / ray.z()))
        rectified.pixels[i].col(j) = *moved;
    }
  }
  return rectified;
}

RankOneResult RectifiedRankOneInit(const FeatureTracks& tracks, const CameraModel& camera,
                                   std::vector<Pose> poses, double readout, int rounds,
                                   const RankOneOptions& options,
                                   const std::vector<double>& times) {
  RankOneResult result;
  for (int round = 0; round < rounds; ++round) {
    const FeatureTracks rectified = RectifyRollingShutter(tracks, camera, poses, readout, times);
    RankOneResult next =
        RankOneInit(rectified, camera, EstimateRotations(rectified, camera), options);
    // The rounds usually converge; where the rank-1 fit gets worse instead
    // (its rotations took translation for rotation), the best round stands.
    if (!next.ok || (result.ok && !(next.rms_residual_px < result.rms_residual_px))) break;
    result = std::move(next);
    poses = result.poses;
  }
  return result;
}

}  // namespace dfsm
