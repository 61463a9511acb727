#include "core/sparse/gain_bias_alignment.h"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

namespace dfsm {
namespace {

bool WindowInside(const cv::Mat& image, cv::Point2f centre, int half) {
  const float h = static_cast<float>(half);
  return centre.x - h >= 0.0f && centre.y - h >= 0.0f &&
         centre.x + h < static_cast<float>(image.cols - 1) &&
         centre.y + h < static_cast<float>(image.rows - 1);
}

}  // namespace

void GainBiasAlignmentOptions::Check() const {
  if (!(window >= 3 && window % 2 == 1))
    throw std::invalid_argument("window must be odd and >= 3, got " + std::to_string(window));
  if (!(weight_sigma_px > 0.0)) throw std::invalid_argument("weight_sigma_px must be > 0");
  if (max_iterations < 1) throw std::invalid_argument("max_iterations must be >= 1");
  if (!(epsilon_px > 0.0)) throw std::invalid_argument("epsilon_px must be > 0");
  if (!(max_shift_px > 0.0)) throw std::invalid_argument("max_shift_px must be > 0");
  if (!(max_shift_fraction >= 0.0)) throw std::invalid_argument("max_shift_fraction must be >= 0");
  if (!(max_gain > 1.0)) throw std::invalid_argument("max_gain must be > 1");
}

GainBiasAligner::GainBiasAligner(const cv::Mat& reference, const GainBiasAlignmentOptions& options)
    : options_(options) {
  options.Check();
  CV_Assert(reference.type() == CV_8UC1);
  reference.convertTo(intensity_, CV_32F);
  // Scharr's derivative, as OpenCV's KLT takes it.
  cv::Scharr(intensity_, dx_, CV_32F, 1, 0, 1.0 / 32.0);
  cv::Scharr(intensity_, dy_, CV_32F, 0, 1, 1.0 / 32.0);
  const int half = options.window / 2;
  for (int v = -half; v <= half; ++v)
    for (int u = -half; u <= half; ++u)
      weights_.push_back(
          std::exp(-0.5 * (u * u + v * v) / (options.weight_sigma_px * options.weight_sigma_px)));
}

bool GainBiasAligner::Prepare(cv::Point2f corner, Patch* patch) const {
  const int half = options_.window / 2;
  if (!WindowInside(intensity_, corner, half)) return false;
  // With dI/dp taken as a dT/dw (the reference's derivative, as in OpenCV's
  // KLT; the frame's own derivative carries its noise into the normal
  // equations and moved the ideal bursts' tracks off KLT's, f 1.45 -> 4.0 %,
  // seed 1), the Jacobian row of window pixel w is [a Tx, a Ty, -T, -1]: the
  // normal matrix is a fixed sum scaled by the gain, and an iteration only
  // accumulates the residual against the four weighted columns.
  const size_t size = weights_.size();
  // The window's samples (OpenCV's bilinear patch extraction; exact copies at
  // the whole-pixel corners the detector gives).
  const cv::Size side(options_.window, options_.window);
  cv::Mat t, tx, ty;
  cv::getRectSubPix(intensity_, side, corner, t, CV_32F);
  cv::getRectSubPix(dx_, side, corner, tx, CV_32F);
  cv::getRectSubPix(dy_, side, corner, ty, CV_32F);
  patch->intensity.assign(t.begin<float>(), t.end<float>());
  patch->weighted.resize(4 * size);
  Eigen::Matrix4d sums = Eigen::Matrix4d::Zero();
  patch->corner = corner;
  const float* t_x = tx.ptr<float>();
  const float* t_y = ty.ptr<float>();
  for (size_t k = 0; k < size; ++k) {
    const Eigen::Vector4d column(t_x[k], t_y[k], patch->intensity[k], 1.0);
    sums.selfadjointView<Eigen::Lower>().rankUpdate(column, weights_[k]);
    for (int c = 0; c < 4; ++c)
      patch->weighted[c * size + k] = static_cast<float>(weights_[k] * column[c]);
  }
  patch->sums = sums.selfadjointView<Eigen::Lower>();
  return true;
}

namespace {

// The residual r = I - a T - b of the window at p, summed against the
// patch's four weighted columns: sum g r [Tx Ty T 1]. `Sample` gives frame
// row v's samples at p (v, and u within it, from -half).
template <class Sample>
Eigen::Vector4d WindowSums(const GainBiasAligner::Patch& patch, int side, float gain, float bias,
                           const Sample& sample) {
  const size_t size = static_cast<size_t>(side) * side;
  const float* w_tx = patch.weighted.data();
  const float* w_ty = w_tx + size;
  const float* w_t = w_ty + size;
  const float* w_1 = w_t + size;
  std::vector<float> row(side);
  Eigen::Vector4d sums = Eigen::Vector4d::Zero();
  for (int v = 0; v < side; ++v) {
    sample(v, row.data());
    const int k0 = v * side;
    float s_tx = 0.0f, s_ty = 0.0f, s_t = 0.0f, s_1 = 0.0f;
    for (int u = 0; u < side; ++u) {
      const float residual = row[u] - gain * patch.intensity[k0 + u] - bias;
      s_tx += residual * w_tx[k0 + u];
      s_ty += residual * w_ty[k0 + u];
      s_t += residual * w_t[k0 + u];
      s_1 += residual * w_1[k0 + u];
    }
    sums += Eigen::Vector4d(s_tx, s_ty, s_t, s_1);
  }
  return sums;
}

}  // namespace

bool GainBiasAligner::Align(const Patch& patch, const cv::Mat& image, cv::Point2f* position) const {
  const int half = options_.window / 2, side = options_.window;
  return Solve(patch, image, half, position, [&](cv::Point2f p, float gain, float bias) {
    // Every window pixel shares p's sub-pixel phase: one set of bilinear weights.
    const float left = p.x - static_cast<float>(half), top = p.y - static_cast<float>(half);
    const int x0 = static_cast<int>(left), y0 = static_cast<int>(top);
    const float ax = left - static_cast<float>(x0), ay = top - static_cast<float>(y0);
    const float w00 = (1.0f - ax) * (1.0f - ay), w01 = ax * (1.0f - ay);
    const float w10 = (1.0f - ax) * ay, w11 = ax * ay;
    return WindowSums(patch, side, gain, bias, [&](int v, float* out) {
      const uchar* row0 = image.ptr<uchar>(y0 + v) + x0;
      const uchar* row1 = image.ptr<uchar>(y0 + v + 1) + x0;
      for (int u = 0; u < side; ++u)
        out[u] = w00 * static_cast<float>(row0[u]) + w01 * static_cast<float>(row0[u + 1]) +
                 w10 * static_cast<float>(row1[u]) + w11 * static_cast<float>(row1[u + 1]);
    });
  });
}

bool GainBiasAligner::Align(const Patch& patch, const cv::Mat& image, const float shape[4],
                            cv::Point2f* position) const {
  const int half = options_.window / 2, side = options_.window;
  // The window's corners reach this far from p through the shape (one pixel
  // more: the samples' rounding must not step past the last pixel).
  const float reach = static_cast<float>(half) * std::max(std::abs(shape[0]) + std::abs(shape[1]),
                                                          std::abs(shape[2]) + std::abs(shape[3]));
  const int stride = static_cast<int>(image.step1());
  const uchar* data = image.ptr<uchar>(0);
  return Solve(patch, image, static_cast<int>(std::ceil(reach)) + 1, position,
               [&](cv::Point2f p, float gain, float bias) {
                 return WindowSums(patch, side, gain, bias, [&](int v, float* out) {
                   // Each sample has a sub-pixel phase of its own.
                   const float dv = static_cast<float>(v - half);
                   for (int u = 0; u < side; ++u) {
                     const float du = static_cast<float>(u - half);
                     const float x = p.x + shape[0] * du + shape[1] * dv;
                     const float y = p.y + shape[2] * du + shape[3] * dv;
                     const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
                     const float ax = x - static_cast<float>(x0), ay = y - static_cast<float>(y0);
                     const uchar* q = data + y0 * stride + x0;
                     const float top = q[0] + ax * (static_cast<float>(q[1]) - q[0]);
                     const float bottom =
                         q[stride] + ax * (static_cast<float>(q[stride + 1]) - q[stride]);
                     out[u] = top + ay * (bottom - top);
                   }
                 });
               });
}

template <class Sums>
bool GainBiasAligner::Solve(const Patch& patch, const cv::Mat& image, int reach,
                            cv::Point2f* position, const Sums& sums) const {
  CV_Assert(image.type() == CV_8UC1 && image.size() == intensity_.size());
  const cv::Point2f start = *position;
  cv::Point2f p = start;
  double gain = 1.0, bias = 0.0;
  bool converged = false;
  for (int iteration = 0; iteration < options_.max_iterations && !converged; ++iteration) {
    if (!WindowInside(image, p, reach)) return false;
    const Eigen::Vector4d r =
        sums(p, static_cast<float>(gain), static_cast<float>(bias));  // sum g r [Tx Ty T 1]
    const Eigen::Vector4d gradient(gain * r[0], gain * r[1], -r[2], -r[3]);
    // J^T g J with J = [a Tx, a Ty, -T, -1]: the sums scaled by diag(a, a, -1, -1).
    const Eigen::Vector4d scale(gain, gain, -1.0, -1.0);
    const Eigen::Matrix4d normal = scale.asDiagonal() * patch.sums * scale.asDiagonal();
    const Eigen::LDLT<Eigen::Matrix4d> solver(normal);
    if (solver.info() != Eigen::Success || !solver.isPositive()) return false;
    const Eigen::Vector4d step = solver.solve(-gradient);
    if (!step.allFinite()) return false;
    p.x += static_cast<float>(step[0]);
    p.y += static_cast<float>(step[1]);
    gain += step[2];
    bias += step[3];
    converged = std::hypot(step[0], step[1]) < options_.epsilon_px;
  }
  // A solve still moving after max_iterations oscillates between two fits of
  // the patch (0-4 of ~2000 realignments per burst): neither is trusted.
  if (!converged) return false;
  const cv::Point2f shift = p - start, travel = start - patch.corner;
  if (std::hypot(shift.x, shift.y) >
      std::max(options_.max_shift_px, options_.max_shift_fraction * std::hypot(travel.x, travel.y)))
    return false;
  if (!(gain > 1.0 / options_.max_gain && gain < options_.max_gain)) return false;
  *position = p;
  return true;
}

}  // namespace dfsm
