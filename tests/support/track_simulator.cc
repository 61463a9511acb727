#include "tests/support/track_simulator.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "core/camera/rolling_shutter.h"

namespace dfsm {

TrackSimulation SimulateTracks(const TrackSimulatorOptions& options) {
  TrackSimulation sim;
  sim.camera = CameraModel::Initial(options.width, options.height);
  sim.camera.f = options.f;
  sim.camera.k1 = options.k1;
  sim.camera.k2 = options.k2;
  std::mt19937_64 random(options.seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, std::max(options.noise_px, 1e-300));
  std::mt19937_64 noise_random(options.noise_seed);
  std::mt19937_64& noise_source = options.noise_seed != 0 ? noise_random : random;

  // Smooth hand motion: centres on a random ellipse-like path, rotations a
  // random axis sweep, both scaled to the requested extents.
  const int n = options.frames;
  const Eigen::Vector3d a(unit(random), unit(random), 0.3 * unit(random));
  const Eigen::Vector3d b(unit(random), unit(random), 0.3 * unit(random));
  const Eigen::Vector3d axis =
      Eigen::Vector3d(unit(random), unit(random), unit(random)).normalized();
  const Eigen::Vector3d axis2 =
      Eigen::Vector3d(unit(random), unit(random), unit(random)).normalized();
  const double deg = M_PI / 180.0;
  for (int i = 0; i < n; ++i) {
    const double t = n > 1 ? static_cast<double>(i) / (n - 1) : 0.0;
    Pose pose;
    if (i > 0) {
      const Eigen::Vector3d centre =
          0.5 * options.baseline * (std::sin(M_PI * t) * a.normalized() + t * b.normalized());
      pose.R = (Eigen::AngleAxisd(options.rotation_deg * deg * t, axis) *
                Eigen::AngleAxisd(0.5 * options.rotation_deg * deg * std::sin(3.0 * t), axis2))
                   .toRotationMatrix();
      pose.T = -pose.R * centre;
    }
    sim.poses.push_back(pose);
  }

  sim.tracks.reference = 0;
  sim.tracks.pixels.assign(n, Eigen::Matrix2Xd(2, 0));
  std::vector<Eigen::Vector2d> reference_pixels;
  const int columns = static_cast<int>(std::round(std::sqrt(options.tracks * 16.0 / 9.0)));
  const int rows = (options.tracks + columns - 1) / columns;
  std::uniform_real_distribution<double> inverse(1.0 / options.max_depth, 1.0 / options.min_depth);
  std::vector<Eigen::Matrix2Xd> pixels(n, Eigen::Matrix2Xd(2, options.tracks));
  const RowPoses row_poses(sim.poses, options.readout, options.height, {},
                           options.angular_velocities);
  int count = 0;
  for (int r = 0; r < rows && count < options.tracks; ++r) {
    for (int c = 0; c < columns && count < options.tracks; ++c) {
      const Eigen::Vector2d pixel((c + 0.5 + 0.3 * unit(random)) * options.width / columns,
                                  (r + 0.5 + 0.3 * unit(random)) * options.height / rows);
      const double w = inverse(random);
      const Eigen::Vector2d x = sim.camera.PixelToUndistorted(pixel);
      bool visible = true;
      // The point in the reference frame (its middle row's camera).
      const Pose reference_row = row_poses.At(0, pixel.y());
      const Eigen::Vector3d X_ref =
          reference_row.R.transpose() * (Eigen::Vector3d(x.x(), x.y(), 1.0) / w - reference_row.T);
      for (int i = 0; i < n && visible; ++i) {
        // The row a point lands on sets the pose it is seen from: a few
        // fixed-point steps settle it (the pose changes little per row).
        std::optional<Eigen::Vector2d> projected = pixel;
        for (int step = 0; step < (options.readout > 0.0 ? 6 : 1) && projected; ++step) {
          const Eigen::Vector3d X = row_poses.At(i, projected->y()).Transform(X_ref);
          projected = sim.camera.UndistortedToPixel(X.head<2>() / X.z());
        }
        if (!projected) {
          visible = false;
          break;
        }
        pixels[i].col(count) = *projected;
      }
      if (!visible) continue;
      if (options.noise_px > 0.0)
        for (int i = 0; i < n; ++i)
          pixels[i].col(count) += Eigen::Vector2d(noise(noise_source), noise(noise_source));
      sim.inverse_depths.push_back(w);
      ++count;
    }
  }
  for (int i = 0; i < n; ++i) sim.tracks.pixels[i] = pixels[i].leftCols(count);
  return sim;
}

}  // namespace dfsm
